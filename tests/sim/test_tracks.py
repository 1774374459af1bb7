"""Several tracks in one scenario (``[[track]]``): every chromosome drives each track, and its
fitness is the mean over them."""

import numpy as np

from enn_traffic.config import load_scenario
from enn_traffic.sim.tracks import TracksWorld
from enn_traffic.sim.world import COLLIDED, make_world

TWO = """
name = "two"
[[track]]
net = "{arena}"
start_xy = [10.0, 50.0]
start_heading_deg = 0.0
[[track]]
net = "{arena}"
start_xy = [40.0, 50.0]
start_heading_deg = 0.0
[[track]]
net = "{narrow}"
start_xy = [0.0, 0.0]
start_heading_deg = 90.0
[sensor]
beams = 3
[episode]
max_steps = 500
"""


def scenario(tmp_path, root):
    path = tmp_path / "two.toml"
    nets = root / "sumo_nets"
    path.write_text(TWO.format(arena=nets / "arena.net.xml", narrow=nets / "track_narrow.net.xml"))
    return load_scenario(path)


def test_fitness_is_the_mean_over_the_tracks(tmp_path, root):
    """Zero weights steer straight ahead: from x = 10 and x = 40 the bumper meets the arena's
    wall at x = 100 after 90 and 60 steps (1 m per step); on the narrow track the first corner
    wall is ahead too. The fitness is the mean of the three."""
    world = make_world(scenario(tmp_path, root))
    assert isinstance(world, TracksWorld)
    population = np.zeros((2, world.spec.chromosome_length))
    population[1] = np.random.default_rng(3).uniform(-1, 1, world.spec.chromosome_length)
    results = world.evaluate(population)
    assert results.steps.shape == (2, 3)
    assert results.steps[0, 0] == 90 and results.steps[0, 1] == 60
    assert (results.outcome[0] == COLLIDED).all()
    alone = [make_world(world.scenario.on_track(i)).evaluate(population) for i in range(3)]
    for index, one in enumerate(alone):
        np.testing.assert_array_equal(results.steps[:, index], one.steps[:, 0])
    np.testing.assert_allclose(results.fitness, np.mean([a.fitness for a in alone], axis=0))
    assert world.situation_labels() == ["arena: none", "arena: none", "track_narrow: none"]


def test_a_trace_is_of_its_own_track(tmp_path, root):
    world = make_world(scenario(tmp_path, root))
    poses, outcome = world.trace(np.zeros(world.spec.chromosome_length), situation=1)
    assert len(poses) == 61 and outcome == COLLIDED
    assert poses[0, 0, 0] == 40.0 and poses[-1, 0, 0] == 100.0
    assert world.world_of(2)[0].track.name == "track_narrow"


def test_a_process_pool_gives_the_same_fitness(tmp_path, root):
    from conftest import local_and_spread

    from enn_traffic.learning.evaluators import ProcessEvaluator

    sc = scenario(tmp_path, root)
    population = np.random.default_rng(4).uniform(-1, 1, (6, make_world(sc).spec.chromosome_length))
    local, spread = local_and_spread(sc, population, 2, ProcessEvaluator(sc, workers=2))
    np.testing.assert_array_equal(local.steps, spread.steps)
    np.testing.assert_array_equal(local.fitness, spread.fitness)
