"""The learner among other vehicles: the blame rule, sensing bodies, strategies, determinism."""

import math

import numpy as np
import pytest
from conftest import TWO_CARS, local_and_spread, two_cars

from enn_traffic.config import load_scenario
from enn_traffic.core.errors import InputError
from enn_traffic.core.geometry import body_polygon
from enn_traffic.sim.arena import ArenaWorld
from enn_traffic.sim.readings import beam_table
from enn_traffic.sim.sensors import sense_bodies
from enn_traffic.sim.world import COLLIDED


def test_head_on_both_responsible_learner_dies_at_the_expected_step(tmp_path, root):
    """Bumpers 20 m apart closing at 2 m per step: after 11 steps each new body reaches into
    the other's body of the step before (both responsible, paper Fig. 5)."""
    world = two_cars(tmp_path, root, (20.0, 50.0), (40.0, 50.0), 180.0)
    results = world.evaluate(np.zeros((1, world.spec.chromosome_length)))
    assert results.outcome[0, 0] == COLLIDED and results.steps[0, 0] == 11


def test_side_impact_by_another_vehicle_is_counted_not_fatal(tmp_path, root):
    """A vehicle driving north runs into the learner's flank at step 5: it is responsible (its
    new body meets the learner's old one, not the reverse), respawns, and the learner lives on
    to the far wall."""
    world = two_cars(tmp_path, root, (27.0, 50.0), (30.0, 44.0), 90.0)
    genes = np.zeros((1, world.spec.chromosome_length))
    results = world.evaluate(genes)
    assert results.suffered[0, 0] >= 1
    assert results.steps[0, 0] > 5
    poses, _ = world.trace(genes[0], max_steps=8)
    assert poses[6, 1, 1] != pytest.approx(50.0 - 6 + 1.0, abs=2.0)  # the other one respawned
    np.testing.assert_allclose(poses[:9, 0, 0], 27.0 + np.arange(9))  # the learner drove on


def test_beams_see_other_vehicles_bodies():
    corners = np.stack([body_polygon(0.0, 0.0, 0.0, 4.3, 2.5),
                        body_polygon(14.3, 0.0, 0.0, 4.3, 2.5)])  # rear bumper at x = 10
    centres = corners.mean(axis=1)
    angles = np.array([-math.pi / 2, 0.0, math.pi / 2])
    readings = np.full(3, 25.0)
    sense_bodies(0, 0.0, 0.0, 1.0, 0.0, beam_table([(a, 25.0) for a in angles]), corners,
                 centres, centres, 0.5 * math.hypot(4.3, 2.5), 0.1, readings, None)
    np.testing.assert_allclose(readings, [25.0, 10.0, 25.0])


@pytest.fixture(scope="module")
def arena(request):
    root = request.config.rootpath
    return ArenaWorld(load_scenario(root / "scenarios" / "arena_strategy1.toml"))


def test_every_world_of_a_generation_meets_the_same_traffic(arena):
    chromosome = np.random.default_rng(0).uniform(-1, 1, arena.spec.chromosome_length)
    results = arena.evaluate(np.repeat(chromosome[None, :], 6, axis=0), key=3)
    assert len(set(results.steps[:, 0].tolist())) == 1
    again = arena.evaluate(chromosome[None, :], key=3)
    np.testing.assert_array_equal(again.steps[0], results.steps[0])


def test_traffic_changes_with_the_generation(arena):
    varying = ArenaWorld(arena.scenario.with_overrides(traffic={"vary": "generation"}))
    first = varying.situations(0)[0]
    second = varying.situations(1)[0]
    assert not np.array_equal(first.start, second.start)
    np.testing.assert_array_equal(first.start[0], second.start[0])  # the learner starts alike
    np.testing.assert_array_equal(first.start, varying.situations(0)[0].start)


def test_fixed_traffic_holds_for_training_but_never_for_held_out_keys(arena):
    """vary = "fixed": every training generation meets generation 0's traffic, while the
    deployment key still draws other traffic, the same as without "fixed"."""
    from enn_traffic.runs.evaluate import EVALUATION_KEY

    fixed = ArenaWorld(arena.scenario.with_overrides(traffic={"vary": "fixed"}))
    varying = ArenaWorld(arena.scenario.with_overrides(traffic={"vary": "generation"}))
    np.testing.assert_array_equal(fixed.situations(0)[0].start, fixed.situations(9)[0].start)
    held_out = fixed.situations(EVALUATION_KEY)[0].start
    assert not np.array_equal(held_out, fixed.situations(0)[0].start)
    np.testing.assert_array_equal(held_out, varying.situations(EVALUATION_KEY)[0].start)


@pytest.mark.parametrize("strategy", [1, 2, 3, 4])
def test_uncontrolled_vehicles_stay_on_the_arena(strategy, root):
    world = ArenaWorld(load_scenario(root / "scenarios" / f"arena_strategy{strategy}.toml"))
    genes = np.zeros(world.spec.chromosome_length)
    genes[-1] = 0.35  # the learner circles gently; the traffic does what its strategy says
    poses, _ = world.trace(genes, max_steps=600)
    traffic = poses[:, 1:, :2]
    assert np.all((traffic > -0.5) & (traffic < 100.5))
    moved = np.hypot(*np.diff(traffic, axis=0).transpose(2, 0, 1))
    assert np.all((moved <= 1.0 + 1e-9) | (moved > 5.0))  # a step of driving, or a respawn
    if strategy == 1:
        assert (moved > 5.0).any()  # random networks crash, and their vehicles respawn


def test_strategies_differ(root):
    """Straight drivers mostly keep their heading; circling ones turn at every step."""
    still = {}
    for strategy in (2, 3):
        world = ArenaWorld(load_scenario(root / "scenarios" / f"arena_strategy{strategy}.toml"))
        poses, _ = world.trace(np.zeros(world.spec.chromosome_length), max_steps=40)
        turned = np.abs(np.diff(np.unwrap(poses[:, 1:, 2], axis=0), axis=0))
        still[strategy] = (turned < 1e-12).mean()
    assert still[2] > 0.5 and still[3] < 0.05


def test_traffic_start_off_the_area_is_refused(tmp_path, root):
    path = tmp_path / "bad.toml"
    path.write_text(TWO_CARS.format(net=root / "sumo_nets" / "arena.net.xml", lx=20, ly=50,
                                    tx=150, ty=50, th=0))
    with pytest.raises(InputError) as info:
        ArenaWorld(load_scenario(path))
    assert info.value.key == "traffic.starts_xy[0]"


def test_process_pool_matches_local_with_traffic(root):
    from enn_traffic.learning.evaluators import ProcessEvaluator

    scenario = load_scenario(root / "scenarios" / "arena_strategy4.toml")
    population = np.random.default_rng(1).uniform(-1, 1, (9, 68))
    local, spread = local_and_spread(scenario, population, 7, ProcessEvaluator(scenario, 2))
    np.testing.assert_array_equal(local.steps, spread.steps)
    np.testing.assert_array_equal(local.suffered, spread.suffered)


@pytest.mark.parametrize("radius", [10.0, 20.0, 30.0])
def test_circle_steering_drives_the_drawn_radius(radius):
    """Holding circle_steering(R) and -circle_steering(R), the bicycle model's poses lie on
    circles of radius R (the circumcircle of three poses), turning left and right."""
    from enn_traffic.sim.bicycle import bicycle_step
    from enn_traffic.sim.strategies import circle_steering

    for side in (1.0, -1.0):
        x, y, heading = 50.0, 50.0, 0.3
        poses = []
        for _ in range(30):
            x, y, heading = bicycle_step(x, y, heading, side * circle_steering(radius, 2.6), 1.0,
                                         2.6)
            poses.append((x, y, heading))
        (ax, ay, _), (bx, by, _), (cx, cy, _) = poses[0], poses[14], poses[29]
        sides = [math.dist((ax, ay), (bx, by)), math.dist((bx, by), (cx, cy)),
                 math.dist((cx, cy), (ax, ay))]
        area = 0.5 * abs((bx - ax) * (cy - ay) - (cx - ax) * (by - ay))
        circumradius = sides[0] * sides[1] * sides[2] / (4.0 * area)
        assert circumradius == pytest.approx(radius, rel=0.02)
        assert np.sign(poses[1][2] - poses[0][2]) == side


def test_turn_side_left_turns_left_where_the_open_side_is_right(tmp_path, root):
    """A straight driver heading north 15 m from the west wall meets the north wall: by the
    open-side rule it turns right (east, heading falls); with turn_side = "left" it turns
    left (heading rises), whichever side is open."""
    world = two_cars(tmp_path, root, (50.0, 20.0), (15.0, 70.0), 90.0)
    genes = np.zeros(world.spec.chromosome_length)
    turned = {}
    for side in ("open", "left"):
        sided = ArenaWorld(world.scenario.with_overrides(traffic={"turn_distance": 10.0,
                                                              "turn_side": side}))
        poses, _ = sided.trace(genes, max_steps=30)
        turned[side] = (poses[30, 1, 2] - poses[0, 1, 2] + math.pi) % (2 * math.pi) - math.pi
    assert turned["open"] < -0.5 and turned["left"] > 0.5


def test_a_turn_begun_6_m_before_a_wall_head_on_hits_it(tmp_path, root):
    """A straight driver heading north from the arena's centre meets the north wall head-on
    (19 beams, 1 m per step): turning left 10 m or 7 m before, it clears the wall (no step
    longer than 1 m); turning 6 m before (arena_strategy2), it hits the wall and respawns
    elsewhere (a jump of more than 10 m)."""
    world = two_cars(tmp_path, root, (10.0, 5.0), (50.0, 50.0), 90.0)
    jumps = {}
    for distance in (10.0, 7.0, 6.0):
        turning = ArenaWorld(world.scenario.with_overrides(
            traffic={"turn_distance": distance, "turn_side": "left"}, sensor={"beams": 19}))
        poses, _ = turning.trace(np.zeros(turning.spec.chromosome_length), max_steps=70)
        jumps[distance] = np.hypot(*np.diff(poses[:, 1, :2], axis=0).T).max()
    assert jumps[10.0] == pytest.approx(1.0) and jumps[7.0] == pytest.approx(1.0)
    assert jumps[6.0] > 10.0


def test_traffic_that_sees_vehicles_turns_away_from_the_learner(tmp_path, root):
    """Head-on at 2 m per step: a straight driver blind to vehicles meets the learner (both
    responsible, the learner dies); one that sees vehicles (19 beams) turns away 20 m before,
    and the learner drives on to the far wall (about 80 steps)."""
    world = two_cars(tmp_path, root, (20.0, 50.0), (60.0, 50.0), 180.0)
    steps = {}
    for sees in (False, True):
        seeing = ArenaWorld(world.scenario.with_overrides(
            traffic={"turn_distance": 20.0, "sees_vehicles": sees}, sensor={"beams": 19}))
        results = seeing.evaluate(np.zeros((1, seeing.spec.chromosome_length)))
        steps[sees] = (int(results.steps[0, 0]), int(results.outcome[0, 0]))
    assert steps[False] == (21, COLLIDED) and steps[True][0] > 60
