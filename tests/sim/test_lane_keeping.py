"""Lane keeping with a real highway-env environment (paper §5.6)."""

import math

import numpy as np
import pandas as pd
import pytest
from conftest import local_and_spread

from enn_traffic.config import LaneKeepingConfig, load_scenario
from enn_traffic.core.errors import InputError
from enn_traffic.learning import ga
from enn_traffic.sim.lane_keeping.road import lane_markings, make_env
from enn_traffic.sim.world import LEFT_LANE, make_world

SCENARIO = """
name = "lk"
seed = 3
[lane_keeping]
road = "{road}"
radius = 60.0
lane_width = 4.0
lookahead_m = [5.0, 10.0]
[ga]
population_size = 20
generations = 5
[episode]
max_steps = 300
"""


def scenario(tmp_path, road="sine"):
    path = tmp_path / "lk.toml"
    path.write_text(SCENARIO.format(road=road))
    return load_scenario(path)


def test_camera_on_a_straight_road_sees_both_markings_at_half_the_width():
    env = make_env(LaneKeepingConfig(amplitude=0.0, lane_width=4.0))
    env.reset(seed=0)
    readings = lane_markings(env.unwrapped.vehicle, [5.0, 10.0, 20.0], 0.0, None)
    np.testing.assert_allclose(readings, [-2.0, 2.0] * 3, atol=1e-9)


def test_camera_on_a_circle_against_hand_computed_offsets():
    """Start at (0, -60) heading along +x on a 60 m circle: the marking at lateral ∓2 m lies on
    radius 62 (58) m; d metres ahead it is at angle φ = d/60 past the start, so its offset in
    the vehicle frame is r·sin(φ − π/2) + 60."""
    env = make_env(LaneKeepingConfig(road="circle", radius=60.0, lane_width=4.0))
    env.reset(seed=0)
    vehicle = env.unwrapped.vehicle
    assert vehicle.position == pytest.approx([0.0, -60.0], abs=1e-9)
    readings = lane_markings(vehicle, [5.0, 10.0], 0.0, None)
    expected = [r * math.sin(d / 60.0 - math.pi / 2) + 60.0 for d in (5.0, 10.0)
                for r in (62.0, 58.0)]
    np.testing.assert_allclose(readings, expected, atol=1e-9)


def test_drive_moves_the_vehicle_exactly_as_step():
    """``drive`` skips highway-env's observation and log, nothing of the motion: the same
    steering sequence leaves two environments in the same state, bit for bit."""
    road = LaneKeepingConfig(amplitude=5.0, period=60.0, lane_width=4.0)
    stepped, driven = make_env(road), make_env(road)
    stepped.reset(seed=0)
    driven.reset(seed=0)
    for steering in np.sin(np.arange(60) / 7.0):
        stepped.step(np.array([steering]))
        driven.unwrapped.drive(np.array([steering]))
    np.testing.assert_array_equal(driven.unwrapped.vehicle.state, stepped.unwrapped.vehicle.state)
    assert driven.unwrapped.vehicle.position[1] != pytest.approx(0.0, abs=0.5)  # it turned


def test_leaving_the_lane_ends_the_life(tmp_path):
    """Steering straight on the 60 m circle, the centre is 2 m off the centre line after
    sqrt(62² − 60²) = 15.6 m, i.e. at step 19 at 0.83 m per step."""
    world = make_world(scenario(tmp_path, "circle"))
    results = world.evaluate(np.zeros((1, world.spec.chromosome_length)))
    assert results.outcome[0, 0] == LEFT_LANE
    assert 17 <= results.steps[0, 0] <= 21


def test_evaluate_with_a_traffic_seed_takes_a_lane_keeping_controller(tmp_path, capsys):
    """``evaluate --traffic-seed`` on a lane-keeping scenario: no traffic to reseed, so the
    same lifetimes as without it (it once failed: "remove the [traffic] keys")."""
    from enn_traffic.cli import main
    from enn_traffic.runs.controller import Controller

    sc = scenario(tmp_path, "circle")
    genes = np.zeros(make_world(sc).spec.chromosome_length)
    Controller.from_scenario(sc, genes, 0.0, 0).save(tmp_path / "c.npz")
    lifetimes = []
    for extra in ([], ["--traffic-seed", "7"]):
        out = tmp_path / f"l{len(extra)}.csv"
        assert main(["evaluate", str(tmp_path / "c.npz"), str(tmp_path / "lk.toml"),
                     "--out", str(out), "--quiet", *extra]) == 0, capsys.readouterr().err
        lifetimes.append(pd.read_csv(out))
    pd.testing.assert_frame_equal(*lifetimes)


def test_evolution_learns_to_keep_the_lane(tmp_path):
    sc = scenario(tmp_path)
    world = make_world(sc)
    rng = np.random.default_rng(sc.seed)
    params = sc.ga
    population = ga.initial_population(rng, params.population_size,
                                       world.spec.chromosome_length, params.init_range)
    best = []
    for generation in range(sc.ga.generations):
        fitness = world.evaluate(population, generation).fitness
        best.append(fitness.max())
        population = ga.next_generation(rng, population, fitness, params)
    assert best[-1] >= 2 * best[0]
    assert max(best) == sc.episode.max_steps  # some controller kept the lane to the cap


def test_process_pool_gives_the_local_lane_keeping_results(tmp_path):
    from enn_traffic.learning.evaluators import ProcessEvaluator

    sc = scenario(tmp_path)
    population = np.random.default_rng(0).uniform(-1, 1, (6, make_world(sc).spec.chromosome_length))
    local, spread = local_and_spread(sc, population, 0, ProcessEvaluator(sc, 2))
    np.testing.assert_array_equal(local.steps, spread.steps)


def test_scenario_needs_exactly_one_task(tmp_path):
    path = tmp_path / "both.toml"
    path.write_text('name = "x"\n[lane_keeping]\n[track]\nnet = "n.net.xml"\n'
                    'start_xy = [0.0, 0.0]\n')
    with pytest.raises(InputError, match="exactly one"):
        load_scenario(path)


@pytest.mark.parametrize("section", ["[sensor]\nbeams = 7", "[vehicle]\nspeed = 20.0",
                                     "[traffic]\nseed = 7"])
def test_a_key_lane_keeping_would_not_read_is_refused(tmp_path, section):
    """Lane keeping drives highway-env's vehicle from its camera: a [sensor], [vehicle] or
    [traffic] key there did nothing before; now it is an error naming the section."""
    path = tmp_path / "lk.toml"
    path.write_text(f'name = "x"\n[lane_keeping]\nroad = "sine"\n{section}\n')
    name = section.split("]")[0] + "]"
    with pytest.raises(InputError, match=rf"\{name[:-1]}\] is not read by lane keeping"):
        load_scenario(path)


@pytest.mark.parametrize("road", ["circle", "sine"])
def test_a_mirrored_road_is_seen_mirrored(road):
    """Mirrored, the road bends the other way: each marking's offset is the other marking's,
    negated (left and right swap sides)."""
    readings = {}
    for mirrored in (False, True):
        env = make_env(LaneKeepingConfig(road=road, radius=60.0, mirrored=mirrored))
        env.reset(seed=0)
        readings[mirrored] = lane_markings(env.unwrapped.vehicle, [5.0, 10.0], 0.0, None)
    assert not np.allclose(readings[False], [-2.0, 2.0, -2.0, 2.0], atol=0.1)  # it bends
    np.testing.assert_allclose(readings[True], -readings[False].reshape(2, 2)[:, ::-1].ravel(),
                               atol=1e-9)


def test_roads_drawn_per_situation(tmp_path):
    path = tmp_path / "lk.toml"
    path.write_text(SCENARIO.format(road="sine") + "[lane_keeping.draw]\nradius = [40.0, 50.0]\n")
    world = make_world(load_scenario(path).with_overrides(lane_keeping={"episodes": 2}))
    roads = [world.road_of(key, episode) for key in range(30) for episode in range(2)]
    assert world.road_of(7, 1) == roads[15]  # a situation's road is its own, every time
    assert {r.road for r in roads} == {"sine", "circle"}
    assert {r.mirrored for r in roads} == {False, True}
    assert all(40.0 <= r.radius <= 50.0 and 2.0 <= r.amplitude <= 7.0 for r in roads)
    assert len({(r.road, r.radius, r.amplitude) for r in roads}) == len(roads)
    results = world.evaluate(np.zeros((2, world.spec.chromosome_length)), key=3)
    assert results.steps.shape == (2, 2) and world.situation_labels() == ["drawn road"] * 2


def test_a_bad_draw_range_is_named(tmp_path):
    path = tmp_path / "lk.toml"
    path.write_text(SCENARIO.format(road="sine") + "[lane_keeping.draw]\nperiod = [90.0, 50.0]\n")
    with pytest.raises(InputError) as info:
        load_scenario(path)
    assert info.value.key == "lane_keeping.draw.period", info.value.key
    assert info.value.message == "must be [smallest, largest]"


def test_a_drawn_road_run_is_chosen_on_validation_roads(tmp_path):
    """Of a drawn-road run's candidates, the one kept is the best on validation roads: at
    least as good there as ``best.npz``, which only one generation's roads chose."""
    from enn_traffic.core import keys
    from enn_traffic.experiments import lanekeeping
    from enn_traffic.experiments.choosing import candidates
    from enn_traffic.runs.controller import Controller
    from enn_traffic.runs.run import RunOutputs, evolve

    path = tmp_path / "lk.toml"
    path.write_text(SCENARIO.format(road="sine").replace("generations = 5", "generations = 3")
                    .replace("max_steps = 300", "max_steps = 80")
                    + "[lane_keeping.draw]\n")
    sc = load_scenario(path).with_overrides(lane_keeping={"episodes": 2})
    evolve(sc, tmp_path / "run", progress=False)
    chosen = lanekeeping.chosen(sc, tmp_path / "run", roads=3)
    pool = candidates(tmp_path / "run", whole_population=True)
    assert any(np.array_equal(chosen, row) for row in pool)
    final = RunOutputs.load(tmp_path / "run").population
    assert all(any(np.array_equal(member, row) for row in pool) for member in final)
    assert len(candidates(tmp_path / "run")) < len(pool)  # more than the elites
    world = make_world(sc.with_overrides(lane_keeping={"episodes": 3}))
    best = Controller.load(tmp_path / "run" / "best.npz").chromosome
    fitness = world.evaluate(np.vstack([chosen, best, pool]), keys.VALIDATION.start).fitness
    assert fitness[0] == fitness[2:].max() >= fitness[1]
