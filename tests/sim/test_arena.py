import numpy as np
import pytest
from conftest import local_and_spread

from enn_traffic.config import load_scenario
from enn_traffic.core.errors import InputError
from enn_traffic.core.neural import NetworkSpec
from enn_traffic.sim.arena import ArenaWorld
from enn_traffic.sim.reference import reference_life
from enn_traffic.sim.rules import spun
from enn_traffic.sim.world import CAPPED, COLLIDED, SPUN

ARENA = """
name = "arena_test"
[track]
net = "{net}"
start_xy = [{x}, {y}]
start_heading_deg = 0.0
[sensor]
beams = 3
[episode]
max_steps = {max_steps}
"""


def arena_world(tmp_path, root, max_steps=1000, x=10.0, y=50.0, **episode):
    """The empty arena; ``episode`` overrides further ``[episode]`` settings."""
    path = tmp_path / "arena.toml"
    path.write_text(ARENA.format(net=root / "sumo_nets" / "arena.net.xml", max_steps=max_steps,
                                 x=x, y=y))
    return ArenaWorld(load_scenario(path).with_overrides(episode=episode))


def test_straight_driving_hits_the_far_wall_at_the_expected_step(tmp_path, root):
    """Zero weights give equal outputs, so steering 0; the bumper starts at x=10 and moves 1 m
    per step, touching the wall x=100 after 90 steps."""
    world = arena_world(tmp_path, root)
    results = world.evaluate(np.zeros((1, world.spec.chromosome_length)))
    assert results.steps[0, 0] == 90 and results.outcome[0, 0] == COLLIDED
    assert results.fitness[0] == 90


def test_circling_in_place_is_a_spin_and_scores_zero(tmp_path, root):
    world = arena_world(tmp_path, root)
    genes = np.zeros(world.spec.chromosome_length)
    genes[-1] = 10.0  # bias into the left output: hard left turn forever
    results = world.evaluate(genes[None, :])
    assert results.outcome[0, 0] == SPUN and results.fitness[0] == 0
    assert results.steps[0, 0] == world.scenario.episode.spin_window - 1


def test_step_cap_ends_a_wide_circle(tmp_path, root):
    """A gentle left loop stays on the arena, escapes the spin test (radius > 11 m) and
    reaches the cap."""
    world = arena_world(tmp_path, root, max_steps=500, x=50.0, y=20.0)
    genes = np.zeros(world.spec.chromosome_length)
    genes[-1] = 0.35  # left output a little above the right: steering ~7.8 degrees
    results = world.evaluate(genes[None, :])
    assert results.outcome[0, 0] == CAPPED and results.steps[0, 0] == 500


def test_the_arena_scenarios_spin_rule_ends_the_wide_circle(tmp_path, root):
    """The same ~19 m loop stays within 17 m on both axes for 30 s: the arena scenarios'
    wider spin rule scores it 0 once the window is full."""
    episode = load_scenario(root / "scenarios" / "arena_strategy1.toml").episode
    world = arena_world(tmp_path, root, max_steps=500, x=50.0, y=20.0,
                        spin_window=episode.spin_window, spin_variance=episode.spin_variance)
    genes = np.zeros(world.spec.chromosome_length)
    genes[-1] = 0.35
    results = world.evaluate(genes[None, :])
    assert results.outcome[0, 0] == SPUN and results.fitness[0] == 0
    assert results.steps[0, 0] == episode.spin_window - 1 < 500


# A second ring behind, shorter (a scenario edit: [[sensor.rings]]), and an uneven front: the
# rangefinder is data, the rules read whatever beams the scenario lists.
REAR_RING = {"rings": [{"beams": 5, "span_deg": 90.0, "range": 8.0, "centre_deg": 180.0},
                       {"beams": 3, "span_deg": 20.0, "range": 40.0}]}


@pytest.mark.parametrize("sensor", [{}, REAR_RING], ids=["paper", "two more rings"])
def test_compiled_episodes_equal_the_plain_reference_loop(sensor, root):
    scenario = load_scenario(root / "scenarios" / "navigation_narrow.toml").with_overrides(
        sensor=sensor)
    world = ArenaWorld(scenario)
    assert world.spec.layer_sizes[0] == 19 + sum(ring["beams"] for ring in
                                                 sensor.get("rings", []))
    rng = np.random.default_rng(11)
    population = rng.uniform(-1, 1, (40, world.spec.chromosome_length))
    results = world.evaluate(population)
    for p in range(len(population)):
        expected = reference_life(world, population[p])
        assert (results.steps[p, 0], results.outcome[p, 0]) == expected
    assert len(set(results.steps[:, 0].tolist())) > 5  # the sample is not trivial


def test_trace_starts_at_the_start_pose_and_ends_where_evaluate_says(root):
    scenario = load_scenario(root / "scenarios" / "navigation_narrow.toml")
    world = ArenaWorld(scenario)
    chromosome = np.random.default_rng(2).uniform(-1, 1, world.spec.chromosome_length)
    poses, outcome = world.trace(chromosome)
    results = world.evaluate(chromosome[None, :])
    assert poses[0, 0] == pytest.approx(world.start)
    assert len(poses) - 1 == results.steps[0, 0] and outcome == results.outcome[0, 0]
    steps = np.hypot(*np.diff(poses[:, 0, :2], axis=0).T)
    assert np.all(steps <= 1.0 + 1e-12) and np.all(steps > 0.7)


def test_wrong_chromosome_length_is_refused(root):
    world = ArenaWorld(load_scenario(root / "scenarios" / "navigation_narrow.toml"))
    with pytest.raises(ValueError, match="needs 68"):
        world.evaluate(np.zeros((2, 20)))


def test_learning_on_the_narrow_track_improves_fitness(root):
    """The real problem, small: 40 vehicles, 12 generations. Untrained, the best stalls
    before the first turns (location A, ~100 steps; paper §5.1); after learning, every one of
    the last four generations' best is past them and the population's mean has risen."""
    from enn_traffic.learning import ga

    scenario = load_scenario(root / "scenarios" / "navigation_narrow.toml").with_overrides(
        ga={"population_size": 40})
    world = ArenaWorld(scenario)
    rng = np.random.default_rng(scenario.seed)
    population = ga.initial_population(rng, 40, world.spec.chromosome_length, 1.0)
    bests, means = [], []
    for _ in range(12):
        fitness = world.evaluate(population).fitness
        bests.append(fitness.max())
        means.append(fitness.mean())
        population = ga.next_generation(rng, population, fitness, scenario.ga)
    assert bests[0] < 100 < min(bests[-4:])
    assert means[-1] > 3 * means[0]


def test_process_pool_gives_the_local_results(root):
    from enn_traffic.learning.evaluators import ProcessEvaluator

    scenario = load_scenario(root / "scenarios" / "navigation_narrow.toml")
    population = np.random.default_rng(5).uniform(-1, 1, (37, 68))
    local, spread = local_and_spread(scenario, population, 0, ProcessEvaluator(scenario, 2))
    np.testing.assert_array_equal(local.fitness, spread.fitness)
    np.testing.assert_array_equal(local.outcome, spread.outcome)


ANYWHERE = """
name = "anywhere"
[track]
net = "{net}"
start_anywhere = true
[traffic]
episodes = 6
"""


def test_start_anywhere_takes_every_spot_with_room_along_the_lane(tmp_path, root):
    # The arena is one 100 m-wide lane along y = 50 from x = 0 to 100: spots every 5 m from
    # 2.5 m. Facing +x the 4.3 m body (behind the bumper) and 10 m ahead must keep 1 m from
    # the walls: 5.3 <= x <= 89, so x = 7.5 ... 87.5; facing -x: 11 <= x <= 94.7, so
    # x = 12.5 ... 92.5. Seventeen each way.
    path = tmp_path / "anywhere.toml"
    path.write_text(ANYWHERE.format(net=root / "sumo_nets" / "arena.net.xml"))
    world = ArenaWorld(load_scenario(path))
    starts = np.array(world.starts)
    east, west = starts[np.cos(starts[:, 2]) > 0.99], starts[np.cos(starts[:, 2]) < -0.99]
    assert len(east) == len(west) == 17 and len(starts) == 34
    assert np.allclose(starts[:, 1], 50.0)
    assert np.allclose(np.sort(east[:, 0]), np.arange(7.5, 88, 5))
    assert np.allclose(np.sort(west[:, 0]), np.arange(12.5, 93, 5))
    # each situation draws its start from the traffic key: the same key, the same starts
    drawn = [tuple(e.start[0]) for e in world.situations(3)]
    assert drawn == [tuple(e.start[0]) for e in world.situations(3)]
    assert len(set(drawn)) > 1 and drawn != [tuple(e.start[0]) for e in world.situations(4)]


def test_start_anywhere_with_a_start_pose_is_refused(tmp_path, root):
    path = tmp_path / "anywhere.toml"
    text = ANYWHERE.format(net=root / "sumo_nets" / "arena.net.xml")
    path.write_text(text.replace("[traffic]", "start_xy = [1.0, 2.0]\n[traffic]"))
    with pytest.raises(InputError) as info:
        load_scenario(path)
    assert info.value.key == "track" and "start_anywhere" in info.value.message


def u_turn(straight: int, radius: float) -> np.ndarray:
    """Positions 1 m apart: ``straight`` m up a corridor, a half circle of ``radius`` m to the
    left, and back down."""
    up = [(0.0, float(y)) for y in range(straight)]
    turn = [(-radius + radius * np.cos(a), straight + radius * np.sin(a))
            for a in np.arange(0, np.pi, 1 / radius)]
    down = [(-2 * radius, float(y)) for y in range(straight, -1, -1)]
    return np.array(up + turn + down)


@pytest.mark.parametrize("window, variance, straight, spin", [
    (49, 64.0, 20, True),  # the paper's rule: 49 m of driving spread over ~21 x 6 m
    (300, 300.0, 150, False),  # the arena's: 300 m cannot stay within 17 m of a dead end
])
def test_a_turn_round_in_a_dead_end_and_the_spin_rules(window, variance, straight, spin):
    # docs/history.md, "Navigation": turning round within 14 m
    path = u_turn(straight, radius=3.0)[:window]
    recent = np.empty((window, 2))
    flags = [spun(recent, step, x, y, variance) for step, (x, y) in enumerate(path)]
    assert len(path) == window and flags[-1] is spin and not any(flags[:-1])


def test_random_network_traffic_is_the_same_whatever_the_learners_network(root):
    # Table 1's traffic (19-3-2 random networks) stays Table 1's when Table 2's learner has 6
    # hidden neurons: the traffic's networks drive the same, vehicle for vehicle.
    base = load_scenario(root / "scenarios" / "arena_strategy1.toml")
    worlds = [ArenaWorld(base.with_overrides(network={"hidden": hidden})) for hidden in ([3], [6])]
    situations = [world.situations(7) for world in worlds]
    specs = [NetworkSpec(world.spec.layer_sizes) for world in worlds]  # genes: source layout
    for small, big in zip(*situations, strict=True):
        assert np.array_equal(small.start, big.start) and small.seed == big.seed
        inputs = np.random.default_rng(1).uniform(0, 25, (len(small.start) - 1, 19))
        assert np.allclose(specs[0].forward(small.traffic_genes[1:], inputs),
                           specs[1].forward(big.traffic_genes[1:], inputs))


def test_traffic_networks_larger_than_the_learners_are_refused(root):
    with pytest.raises(InputError) as info:
        load_scenario(root / "scenarios" / "arena_strategy1.toml").with_overrides(
            network={"hidden": [2]})
    assert info.value.key == "traffic.network_hidden"


def test_a_controller_keeps_its_rings(root, tmp_path):
    """A controller evolved with further rings carries them: fitted to the plain scenario it
    drives with its own 27 beams, as it did in its world."""
    from enn_traffic.runs.controller import Controller

    ringed = load_scenario(root / "scenarios" / "navigation_narrow.toml").with_overrides(
        sensor=REAR_RING)
    world = ArenaWorld(ringed)
    chromosome = np.random.default_rng(5).uniform(-1, 1, world.spec.chromosome_length)
    Controller.from_scenario(ringed, chromosome, 0.0, 0).save(tmp_path / "ringed.npz")
    controller = Controller.load(tmp_path / "ringed.npz")
    fitted = controller.fit(load_scenario(root / "scenarios" / "navigation_narrow.toml"))
    assert fitted.beams == ringed.beams and len(fitted.beams) == 27
    assert ArenaWorld(fitted).evaluate(chromosome[None]).steps[0, 0] == world.evaluate(
        chromosome[None]).steps[0, 0]


def test_the_learner_alone_kernel_drives_as_the_kernel_with_traffic_rules(small):
    """With no traffic the kernels take ``kinds`` as None and compile without the traffic's
    rules (``arena.alone``); every life of a random population, and a traced path, are the
    same as the kernel with every rule gives them for a world of one vehicle."""
    from enn_traffic.sim.arena import run_life, run_population

    world = ArenaWorld(small)
    situation = world.situations(0)[0]
    assert situation.kinds.shape == (1,)
    population = np.random.default_rng(3).uniform(-1, 1, (40, world.spec.chromosome_length))
    genes = world.spec.in_source_layout(population)
    args = (world.layer_sizes, situation.start)
    rest = (situation.traffic_genes, world.physics, world.geometry, situation.seed, 2_000)
    alone = run_population(genes, *args, None, *rest)
    every_rule = run_population(genes, *args, situation.kinds, *rest)
    for column, other in zip(alone, every_rule, strict=True):
        np.testing.assert_array_equal(column, other)
    assert len(set(alone[0])) > 5  # lives of many lengths, some of them long
    best = int(np.argmax(alone[0]))
    paths = [np.full((alone[0][best] + 1, 1, 3), np.nan) for _ in range(2)]
    for kinds, path in zip((None, situation.kinds), paths, strict=True):
        run_life(genes[best], *args, kinds, *rest, path)
    np.testing.assert_array_equal(paths[0], paths[1])
