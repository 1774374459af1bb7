"""The arena and navigation worlds as gymnasium environments: API compliance, seeding, and
the same trajectories as the GA's worlds for the same actions."""

import os
import subprocess
import sys
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

from enn_traffic.config import load_scenario
from enn_traffic.config.shipped import shipped_scenario
from enn_traffic.core import keys
from enn_traffic.envs import REGISTERED, env_id, make_env
from enn_traffic.envs.rangefinder import RangefinderEnv, RangefinderVectorEnv, action_of
from enn_traffic.runs.controller import Controller
from enn_traffic.sim.arena import ArenaWorld


def drive(env, forward, options):
    """One life in ``env`` with the network ``forward`` choosing each action: its steps,
    outcome and return."""
    observation, _ = env.reset(options=options)
    total = 0.0
    while True:
        observation, reward, terminated, truncated, info = env.step(forward(observation))
        total += reward
        if terminated or truncated:
            return info["steps"], info["outcome"], total


@pytest.mark.parametrize("name", REGISTERED)
def test_every_registered_id_passes_the_checker(name):
    """The arena and navigation ids, and the SUMO ones (a SUMO recording or warm-up per
    situation the checker's seeds draw: up to half a minute each, cold)."""
    env = gym.make(env_id(name), render_mode="rgb_array")
    check_env(env.unwrapped)
    first, _ = env.reset(seed=5)
    again, _ = env.reset(seed=5)
    np.testing.assert_array_equal(first, again)
    frame = env.render()
    assert frame.ndim == 3 and frame.shape[2] == 3 and frame.dtype == np.uint8
    env.close()


def test_every_wall_is_drawn_inside_the_frame():
    """The narrow track's walls reach its bounding box: with the frame cut at the box, the
    end wall of the right-hand corridor was not drawn (a newcomer's probe). Every wall lies
    inside a margin now: no wall pixel on the image's edge."""
    env = gym.make(env_id("navigation_narrow"), render_mode="rgb_array")
    env.reset(seed=0)
    dark = env.render().sum(axis=2) < 200
    assert dark.any()
    assert not (dark[0].any() or dark[-1].any() or dark[:, 0].any() or dark[:, -1].any())


def test_a_saved_controller_lives_as_long_in_the_env_as_in_the_gas_world(root):
    controller = Controller.load(root / "results/paper/controllers/generalization/"
                                        "navigation_narrow_seed1.npz")
    env = RangefinderEnv(controller.fit(shipped_scenario("navigation_narrow")),
                         observation_dtype="float64")  # the GA's readings, unrounded
    world = env.world
    expected = world.evaluate(controller.chromosome[None], keys.TEST.start)
    steps, outcome, total = drive(env, lambda o: action_of(world.spec.forward(
        controller.chromosome, o)[0]),
                                  {"key": keys.TEST.start, "situation": 0})
    assert expected.steps[0, 0] > 1000  # a long life: it reaches the track's far end
    assert steps == expected.steps[0, 0]
    assert total == expected.fitness[0]


def test_random_controllers_among_traffic_live_as_long_in_the_env():
    env = RangefinderEnv(shipped_scenario("arena_strategy1"), observation_dtype="float64")
    world = env.world
    population = np.random.default_rng(3).uniform(-1, 1, (3, world.spec.chromosome_length))
    key = keys.VALIDATION.start
    expected = world.evaluate(population, key)
    for p, chromosome in enumerate(population):
        for situation in range(expected.steps.shape[1]):
            steps, _, total = drive(env, lambda o, c=chromosome: action_of(
                world.spec.forward(c, o)[0]),
                                    {"key": key, "situation": situation})
            assert steps == expected.steps[p, situation]
            assert total == (0 if expected.outcome[p, situation] == 2 else steps)


def test_the_vector_env_steps_each_world_as_the_single_env_does():
    scenario = shipped_scenario("arena_strategy1")
    vector = gym.make_vec(env_id("arena_strategy1"), num_envs=4,
                          vectorization_mode="vector_entry_point")
    assert isinstance(vector, RangefinderVectorEnv)
    key = keys.VALIDATION.start
    observations, _ = vector.reset(options={"keys": [key]})
    single = RangefinderEnv(scenario)
    actions = np.random.default_rng(0).uniform(-1, 1, (40, 4, 2)).astype(np.float32)
    ended_at = {}
    for situation in range(4):
        observation, _ = single.reset(options={"key": key, "situation": situation})
        np.testing.assert_array_equal(observation, observations[situation])
    trajectories = [[] for _ in range(4)]
    for t, action in enumerate(actions):
        observations, rewards, terminated, truncated, info = vector.step(action)
        for i in range(4):
            if i in ended_at:
                continue
            done = terminated[i] or truncated[i]
            trajectories[i].append(info["final_obs"][i] if done else observations[i])
            if done:
                ended_at[i] = t
                assert info["_final_info"][i]
    assert ended_at, "random actions end some lives within 40 steps"
    for situation in range(4):
        single.reset(options={"key": key, "situation": situation})
        for t, expected in enumerate(trajectories[situation]):
            observation, *_ = single.step(actions[t, situation])
            np.testing.assert_array_equal(observation, expected)


def test_the_same_seed_gives_the_same_vector_run():
    def run(seed):
        vector = RangefinderVectorEnv(shipped_scenario("arena_strategy3"), 8, situations=4)
        observations, _ = vector.reset(seed=seed)
        rewards = []
        for action in np.random.default_rng(1).random((30, 8, 2)):
            observations, reward, *_ = vector.step(action)
            rewards.append(reward)
        return observations, np.array(rewards)

    first, again, other = run(7), run(7), run(8)
    np.testing.assert_array_equal(first[0], again[0])
    np.testing.assert_array_equal(first[1], again[1])
    assert not np.array_equal(first[0], other[0])


def test_a_scenario_of_several_tracks_drives_the_one_named(root):
    """navigation_mixed has five tracks: ``track=i`` drives the i-th (its walls, its
    vector env), and without it, or past the last, a clear error says what to pass."""
    path = root / "scenarios/navigation_mixed.toml"
    with pytest.raises(ValueError, match=r"has 5: pass track=0 … 4"):
        make_env(path)
    with pytest.raises(ValueError, match="track=5, but the scenario has 5 tracks"):
        make_env(path, track=5)
    scenario = load_scenario(path)
    for track in (0, 3):
        env = gym.make("enn_traffic/Scenario-v0", scenario=str(path), track=track)
        check_env(env.unwrapped, skip_render_check=True)
        alone = ArenaWorld(scenario.on_track(track))
        np.testing.assert_array_equal(env.unwrapped.world.geometry.walls, alone.geometry.walls)
        vector = gym.make_vec("enn_traffic/Scenario-v0", num_envs=3, scenario=str(path),
                              track=track, vectorization_mode="vector_entry_point")
        np.testing.assert_array_equal(vector.world.geometry.walls, alone.geometry.walls)
    walls = [ArenaWorld(scenario.on_track(t)).geometry.walls for t in (0, 3)]
    assert walls[0].shape != walls[1].shape or not np.array_equal(*walls)


def test_scenarios_an_env_cannot_drive_are_refused(root):
    with pytest.raises(ValueError, match="not an arena or navigation"):
        RangefinderVectorEnv(root / "scenarios/sumo_strategy1.toml")


@pytest.mark.full
def test_the_vector_env_compiled_before_anything_else_steps_as_the_single_env(tmp_path):
    """The test above alone, in a fresh process with an empty numba cache, so that the vector
    env's parallel kernels compile first. Compiled in that order with a world's start and step
    inlined into the parallel loop, the worlds lost writes: no world moved on to its next
    situation, a new life kept the old one's step count, and every life reported 0 steps."""
    alone = test_the_vector_env_steps_each_world_as_the_single_env_does.__name__
    test = f"{Path(__file__).resolve()}::{alone}"
    done = subprocess.run(
        [sys.executable, "-m", "pytest", "-q", "-n", "0", "-p", "no:cacheprovider", test],
        env=os.environ | {"NUMBA_CACHE_DIR": str(tmp_path)}, capture_output=True, text=True,
        timeout=900)
    assert done.returncode == 0, done.stdout[-3000:]


def test_a_broken_file_in_the_scenarios_folder_leaves_the_other_ids(root, tmp_path, monkeypatch):
    """A scenario a user broke in the shipped folder costs its own id, with a warning naming
    its file and key, not the import of every environment."""
    import enn_traffic.envs as envs

    text = (root / "scenarios" / "navigation_narrow.toml").read_text().replace(
        '"../sumo_nets/', f'"{root}/sumo_nets/')
    (tmp_path / "probe_good.toml").write_text(text)
    (tmp_path / "probe_bad.toml").write_text(
        text.replace("[sensor]\n", '[sensor]\nchannels = ["closing_speed"]\n'))
    monkeypatch.setattr(envs, "SCENARIOS", tmp_path)
    with pytest.warns(UserWarning, match="probe_bad.toml: sensor.channels"):
        assert envs.register_envs() == ("probe_good",)
    gym.envs.registration.registry.pop(env_id("probe_good"))


@pytest.mark.parametrize("count", [0, -2, 2.0])
def test_a_vector_env_of_no_whole_number_of_worlds_is_refused(count):
    """``num_envs`` 0, negative or not a whole number is refused naming it (0 gave a vector
    env of no worlds); a numpy integer is a whole number."""
    with pytest.raises(ValueError, match="num_envs"):
        gym.make_vec(env_id("navigation_narrow"), num_envs=count,
                     vectorization_mode="vector_entry_point")
    env = gym.make_vec(env_id("navigation_narrow"), num_envs=np.int64(2),
                       vectorization_mode="vector_entry_point")
    assert env.num_envs == 2
    env.close()
