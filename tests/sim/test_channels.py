"""The rangefinder's further channels (``[sensor] channels``): the closing speed of what each
beam meets, against hand-computed values, in every world that senses, and the distances it
leaves as they were."""

import math

import numpy as np
import pytest

from enn_traffic.config import load_scenario
from enn_traffic.config.shipped import shipped_scenario
from enn_traffic.core.errors import InputError
from enn_traffic.core.geometry import body_polygon
from enn_traffic.envs.rangefinder import RangefinderEnv, action_of
from enn_traffic.envs.sumo import SumoEnv
from enn_traffic.runs.controller import Controller
from enn_traffic.sim.arena import ArenaWorld
from enn_traffic.sim.readings import beam_table, channel_codes, fill_each_channel
from enn_traffic.sim.sensors import sense_bodies, sense_walls

BOTH = {"channels": ["distance", "closing_speed"]}
RADIUS = 0.5 * math.hypot(4.3, 2.5)


def closing_speeds(table, corners, centres, before, walls=None, speed=10.0, dt=0.1):
    """Readings of a vehicle at the origin heading along x at ``speed``, distances then
    closing speeds, among the bodies ``corners`` that were at ``before`` a step ago."""
    count = table.shape[0]
    readings = np.empty(2 * count)
    walls = np.zeros((0, 4)) if walls is None else walls
    sense_walls(0.0, 0.0, 1.0, 0.0, table, walls, np.arange(len(walls)), readings)
    seen = np.zeros((count, 2))
    sense_bodies(-1, 0.0, 0.0, 1.0, 0.0, table, corners, centres, before, RADIUS, dt, readings,
                 seen)
    fill_each_channel(channel_codes(["distance", "closing_speed"]), table, seen, 1.0, 0.0,
                      speed, readings)
    return readings[:count], readings[count:]


@pytest.mark.parametrize(("moved", "expected"), [(0.5, 5.0), (-1.0, 20.0), (1.5, -5.0),
                                                 (0.0, 10.0)])
def test_closing_speed_of_a_body_ahead(moved, expected):
    """A body 10 m ahead that moved ``moved`` m along x in the last 0.1 s step: the beam
    ahead closes on it at 10 m/s less its 10 × moved m/s; the beams to the sides meet
    nothing and read 0."""
    corners = body_polygon(14.3, 0.0, 0.0, 4.3, 2.5)[None]  # rear bumper at x = 10
    centres = corners.mean(axis=1)
    before = centres - [moved, 0.0]
    table = beam_table([(-math.pi / 2, 25.0), (0.0, 25.0), (math.pi / 2, 25.0)])
    distance, closing = closing_speeds(table, corners, centres, before)
    np.testing.assert_allclose(distance, [25.0, 10.0, 25.0])
    np.testing.assert_allclose(closing, [0.0, expected, 0.0], atol=1e-12)


def test_closing_speed_of_a_wall_and_of_a_body_crossing():
    """A wall 20 m ahead across the road: a beam at 60° closes on it at 10 cos 60° = 5 m/s.
    A body 8 m to the left driving along +y at 5 m/s: the beam at 90° meets it and closes at
    −5 m/s (it draws away), the vehicle's own speed adding nothing across its heading."""
    walls = np.array([[20.0, -50.0, 20.0, 50.0]])
    corners = body_polygon(0.0, 12.3, math.pi / 2, 4.3, 2.5)[None]  # rear bumper at y = 8
    centres = corners.mean(axis=1)
    before = centres - [0.0, 0.5]
    table = beam_table([(0.0, 40.0), (math.pi / 3, 50.0), (math.pi / 2, 25.0)])
    distance, closing = closing_speeds(table, corners, centres, before, walls)
    np.testing.assert_allclose(distance, [20.0, 40.0, 8.0])
    np.testing.assert_allclose(closing, [10.0, 5.0, -5.0], atol=1e-12)


def test_the_arena_reads_distances_as_before_then_closing_speeds(root):
    """An arena scenario with both channels: twice the network's inputs and the observation,
    the distances the plain scenario's bit for bit, and at the start, where every other
    vehicle has just been placed (no motion yet), what a beam meets closes at the learner's
    speed along the beam."""
    plain = load_scenario(root / "scenarios" / "arena_strategy1.toml")
    both = plain.with_overrides(sensor=BOTH)
    assert both.inputs == 2 * plain.inputs == 38
    envs = [RangefinderEnv(scenario, observation_dtype="float64") for scenario in (plain, both)]
    (first, _), (second, _) = (env.reset(seed=4) for env in envs)
    beams = both.sensor.beams
    np.testing.assert_array_equal(second[:beams], first)
    angles = np.array(both.beam_angles)
    met = first < 25.0
    assert met.any() and not met.all()
    np.testing.assert_allclose(second[beams:], np.where(met, 10.0 * np.cos(angles), 0.0),
                               atol=1e-12)
    assert envs[1].observation_space.contains(second.astype(np.float64))
    world = ArenaWorld(both)
    chromosome = np.random.default_rng(2).uniform(-1, 1, (4, world.spec.chromosome_length))
    assert world.evaluate(chromosome).steps.min() >= 1  # the GA's kernels drive it


def test_a_sensor_of_distances_alone_carries_no_channel_arrays(root):
    """Distances alone compile without the channels' work: the geometry's channels, the
    step's and the vector env's ``seen`` work arrays are None (a type of its own to numba);
    with closing speed, codes and a (B, 2) array each. Both read distances bit for bit."""
    from enn_traffic.envs.batch import Worlds
    from enn_traffic.sim.rules import work_for

    plain = load_scenario(root / "scenarios" / "arena_strategy1.toml")
    for scenario, alone in ((plain, True), (plain.with_overrides(sensor=BOTH), False)):
        world = ArenaWorld(scenario)
        work = work_for(world.geometry, world.layer_sizes, world.vehicles)
        worlds = Worlds.empty(3, world, world.spec.chromosome_length)
        if alone:
            assert world.geometry.channels is None and work.seen is None
            assert worlds.seen is None
        else:
            assert list(world.geometry.channels) == list(channel_codes(BOTH["channels"]))
            assert work.seen.shape == (scenario.sensor.beams, 2)
            assert worlds.seen.shape == (3, scenario.sensor.beams, 2)


def test_sumo_vehicles_motion_reaches_the_channel(root):
    """Among SUMO's recorded traffic (the closed-loop crowd's, whose learners sense SUMO's
    vehicles and each other: tests/envs/test_sumo_crowd_env.py): the distances are the plain
    scenario's bit for bit, a beam that meets nothing reads 0, and the beams that meet moving
    vehicles read another closing speed than a standing wall's (the learner's speed along the
    beam), within what a car's speed allows."""
    controller = Controller.load(root / "results/paper/controllers/sumo/table1/strategy1.npz")
    plain = controller.fit(shipped_scenario("sumo_strategy1"))
    both = plain.with_overrides(sensor=BOTH)
    beams, speed = plain.sensor.beams, plain.vehicle.speed
    along = speed * np.cos(np.array(plain.beam_angles))
    envs = [SumoEnv(scenario, observation_dtype="float64") for scenario in (plain, both)]
    moving = 0
    try:
        observations = [env.reset(options={"key": 0, "situation": 0})[0] for env in envs]
        for _ in range(300):
            first, second = observations
            np.testing.assert_array_equal(second[:beams], first)
            closing = second[beams:]
            assert np.all(closing[first >= plain.sensor.range] == 0.0)
            other = np.abs(closing - along)[first < plain.sensor.range]
            assert np.all(other < 60.0)
            moving += int((other > 0.5).sum())
            action = action_of(envs[0].world.spec.forward(controller.chromosome, first)[0])
            steps = [env.step(action) for env in envs]
            observations = [step[0] for step in steps]
            if steps[0][2] or steps[0][3]:
                break
    finally:
        for env in envs:
            env.close()
    assert moving > 10, moving


def test_a_controller_keeps_its_channels(root, tmp_path):
    """A controller carries the channels it was evolved with, as it carries its rings: one
    evolved with closing speeds reads them again fitted to the plain scenario, and a plain
    one fitted to a scenario with both reads distances only, as it learnt to."""
    plain = load_scenario(root / "scenarios" / "navigation_narrow.toml")
    both = plain.with_overrides(sensor=BOTH)
    for scenario, other, name in ((both, plain, "both"), (plain, both, "plain")):
        chromosome = np.random.default_rng(5).uniform(
            -1, 1, ArenaWorld(scenario).spec.chromosome_length)
        Controller.from_scenario(scenario, chromosome, 0.0, 0).save(tmp_path / f"{name}.npz")
        fitted = Controller.load(tmp_path / f"{name}.npz").fit(other)
        assert fitted.sensor.channels == scenario.sensor.channels
        assert fitted.inputs == scenario.inputs


@pytest.mark.parametrize(("channels", "message"), [
    (["closing_speed"], "first channel is `distance`"),
    (["distance", "closing_speed", "closing_speed"], "at most 2 items|named twice"),
    (["distance", "speed"], "closing_speed"),
])
def test_bad_channels_are_refused_naming_the_key(root, channels, message):
    with pytest.raises(InputError, match=message) as info:
        load_scenario(root / "scenarios" / "arena_strategy1.toml").with_overrides(
            sensor={"channels": channels})
    assert info.value.key.startswith("sensor.channels")


def test_distances_alone_leave_a_scenarios_settings_as_they_were(root):
    """Naming the default channel changes nothing a run compares or digests: the scenario's
    settings read the same with and without ``channels = ["distance"]``."""
    from enn_traffic.config import scenario_digest

    plain = load_scenario(root / "scenarios" / "arena_strategy1.toml")
    named = plain.with_overrides(sensor={"channels": ["distance"]})
    assert "channels" not in plain.model_dump()["sensor"]
    assert scenario_digest(named) == scenario_digest(plain)
    assert scenario_digest(plain.with_overrides(sensor=BOTH)) != scenario_digest(plain)
