"""The environments keep the field's conventions (issue 52): float32 spaces, a symmetric
action box, ids found without an import, the same info single and vectorised, one autoreset
mode, an AEC environment beside the parallel one, and no action for an agent that is gone."""

import json
import subprocess
import sys

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.vector import AutoresetMode
from pettingzoo.test import api_test, parallel_seed_test

from enn_traffic.config.shipped import shipped_scenario
from enn_traffic.core import keys
from enn_traffic.envs import env, env_id, make_vector_env, parallel_env
from enn_traffic.envs.rangefinder import END_KEYS, RangefinderEnv, forces


@pytest.mark.parametrize("name", ["navigation_narrow", "arena_strategy1"])
def test_spaces_are_float32_and_the_action_box_symmetric(name):
    made = gym.make(env_id(name))
    assert made.observation_space.dtype == np.float32
    assert made.action_space == gym.spaces.Box(-1.0, 1.0, (2,), np.float32)
    observation, _ = made.reset(seed=0)
    assert observation.dtype == np.float32 and made.observation_space.contains(observation)
    spec = json.loads(made.spec.to_json())
    assert spec["max_episode_steps"] == shipped_scenario(name).episode.max_steps


def test_an_action_is_the_papers_outputs_rescaled():
    """forces = (action + 1) / 2, clipped to the box: -1 is no force, 1 full force."""
    np.testing.assert_array_equal(forces([-1.0, 1.0]), [0.0, 1.0])
    np.testing.assert_array_equal(forces([0.0, 0.5]), [0.5, 0.75])
    np.testing.assert_array_equal(forces([-7.0, 3.0]), [0.0, 1.0])


def test_every_id_is_found_by_naming_the_module_without_an_import():
    """gymnasium 1.x has no plugin entry points: "module:id" imports the module itself."""
    code = ("import gymnasium as gym; "
            "e = gym.make('enn_traffic.envs:enn_traffic/NavigationNarrow-v0'); "
            "print(e.spec.max_episode_steps, len(gym.registry))")
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert result.returncode == 0, result.stderr
    assert result.stdout.split()[0] == "20000"


def test_scenario_v0_takes_a_shipped_name_as_the_command_line_does():
    made = gym.make("enn_traffic/Scenario-v0", scenario="arena_strategy2")
    assert made.unwrapped.world.scenario.name == "arena_strategy2"


def test_the_vector_env_tells_what_the_single_env_tells():
    """The same keys and outcome names at a life's end, and the situation at reset."""
    scenario = shipped_scenario("arena_strategy1")
    key = keys.VALIDATION.start
    vector = make_vector_env(scenario, num_envs=4)
    assert vector.metadata["autoreset_mode"] == AutoresetMode.SAME_STEP
    _, reset_info = vector.reset(options={"keys": [key]})
    assert list(reset_info["key"]) == [key] * 4 and list(reset_info["situation"]) == [0, 1, 2, 3]
    actions = np.random.default_rng(0).uniform(-1, 1, (60, 4, 2)).astype(np.float32)
    ended = None
    for action in actions:
        *_, info = vector.step(action)
        if "final_info" in info:
            ended = int(np.flatnonzero(info["_final_info"])[0])
            final = {name: info["final_info"][name][ended] for name in info["final_info"]
                     if not name.startswith("_")}
            break
    assert ended is not None, "random actions end a life within 60 steps"
    single = RangefinderEnv(scenario)
    single.reset(options={"key": key, "situation": ended})
    for action in actions[:, ended]:
        *_, terminated, truncated, info = single.step(action)
        if terminated or truncated:
            break
    assert set(info) == set(final) == {*END_KEYS, "key", "situation"}
    assert isinstance(final["outcome"], str)
    assert {name: final[name] for name in info} == info


def test_sumo_vector_envs_reset_in_the_same_step_too():
    vector = make_vector_env(shipped_scenario("sumo_strategy1"), num_envs=2)
    assert vector.metadata["autoreset_mode"] == AutoresetMode.SAME_STEP
    vector.close()


@pytest.mark.parametrize("name", ["arena_strategy1", "sumo_strategy1"])
def test_both_crowds_pass_pettingzoos_aec_api_test_and_parallel_seed_test(name):
    """The arena's crowd and SUMO's (the second SUMO crowd runs in a child process)."""
    aec = env(shipped_scenario(name), learners=3)
    api_test(aec, num_cycles=100)
    aec.close()
    parallel_seed_test(lambda: parallel_env(shipped_scenario(name), learners=3), num_cycles=100)


def test_an_action_for_an_agent_that_is_gone_is_an_error():
    crowd = parallel_env(shipped_scenario("arena_strategy1"), learners=3)
    crowd.reset(seed=1)
    actions = {agent: crowd.action_space(agent).sample() for agent in crowd.agents}
    with pytest.raises(KeyError, match="not a live agent"):
        crowd.step({**actions, "vehicle_9": np.zeros(2, np.float32)})
    with pytest.raises(KeyError, match="no action for vehicle_2"):
        crowd.step({agent: actions[agent] for agent in ("vehicle_0", "vehicle_1")})


def test_a_nan_or_misshaped_action_is_an_error_not_a_silent_drive():
    """A NaN action left the pose NaN for good while every beam read its range; a vector
    action of the wrong shape read memory past its end."""
    single = gym.make(env_id("arena_strategy1")).unwrapped
    single.reset(seed=0)
    with pytest.raises(ValueError, match="NaN"):
        single.step(np.array([np.nan, 0.0], np.float32))
    with pytest.raises(ValueError, match="shape"):
        single.step(np.zeros(3, np.float32))
    vector = make_vector_env(shipped_scenario("arena_strategy1"), num_envs=4)
    with pytest.raises(gym.error.ResetNeeded):
        vector.step(np.zeros((4, 2), np.float32))
    vector.reset(seed=0)
    for shape in [(2, 2), (4,), (8, 2), (4, 3)]:
        with pytest.raises(ValueError, match="shape"):
            vector.step(np.zeros(shape, np.float32))


def test_a_step_after_the_life_ended_asks_for_a_reset():
    """It went on returning terminated with rewards of -299, -300, ... after a spin."""
    made = RangefinderEnv(shipped_scenario("navigation_wide"))
    made.reset(seed=0)
    terminated = truncated = False
    while not (terminated or truncated):
        _, _, terminated, truncated, _ = made.step(np.array([1.0, -1.0], np.float32))
    with pytest.raises(gym.error.ResetNeeded):
        made.step(np.zeros(2, np.float32))


def test_an_env_pickles_after_reset():
    import pickle

    made = gym.make(env_id("arena_strategy1")).unwrapped
    made.reset(seed=3)
    again = pickle.loads(pickle.dumps(made))
    action = np.array([0.2, -0.4], np.float32)
    np.testing.assert_array_equal(made.step(action)[0], again.step(action)[0])


@pytest.mark.parametrize("options, message", [
    ({"situaton": 0}, "reset options ['situaton']: the options are ['key', 'situation']"),
    ({"key": 1.5}, "reset option key=1.5: a whole number (int) or None"),
    ({"situation": True}, "reset option situation=True: a whole number (int) or None"),
])
def test_a_misspelt_or_fractional_reset_option_is_an_error(options, message):
    """Issue 64: a misspelt option or a float key was accepted silently (the key drawn at
    random, the float truncated). The PettingZoo crowd warns of an option it does not know
    (PettingZoo's own API test resets with one), and refuses a bad value."""
    single = gym.make(env_id("navigation_narrow"))
    with pytest.raises(ValueError) as error:
        single.reset(seed=1, options=options)
    assert str(error.value) == message
    crowd = parallel_env("arena_strategy1", learners=2)
    if "situaton" in options:
        with pytest.warns(UserWarning, match=r"\['situaton'\].*; the others are ignored"):
            crowd.reset(seed=1, options=options)
    else:
        with pytest.raises(ValueError, match=message.replace("(", r"\(").replace(")", r"\)")):
            crowd.reset(seed=1, options=options)
    vector = make_vector_env("navigation_narrow", num_envs=2)
    with pytest.raises(ValueError, match=r"reset options \['key'\]: the options are \['keys'\]"):
        vector.reset(options={"key": 1})


def test_a_render_mode_the_env_does_not_have_is_an_error():
    """Issue 64: ``render_mode="human"`` was accepted and ignored."""
    with pytest.raises(ValueError, match=r"render_mode='human': this environment renders "
                                         r"\['rgb_array'\] \(or None\)"):
        make_vector_env("navigation_narrow", num_envs=2, render_mode="human")
    with pytest.raises(ValueError, match="render_mode='human'"):
        parallel_env("arena_strategy1", learners=2, render_mode="human")


def test_the_vector_env_renders_its_first_worlds_as_a_grid():
    """Issue 65: render() drew world 0 alone. Five worlds: a grid of 3 columns, 2 rows, each
    tile the world's own picture (its own traffic, not world 0's), a blank sixth."""
    from enn_traffic.envs.rangefinder import RENDERED_WORLDS, picture

    vector = make_vector_env("arena_strategy1", num_envs=5, render_mode="rgb_array")
    vector.reset(options={"keys": [keys.VALIDATION.start + k for k in range(5)]})
    vector.step(np.zeros((5, 2), np.float32))
    image = vector.render()
    w = vector.batch.worlds
    tiles = [picture(vector.world, w.corners[i], w.pose[i], w.observation[i:i + 1])
             for i in range(5)]
    height, width, _ = tiles[0].shape
    assert image.shape == (2 * height, 3 * width, 3)
    for i, tile in enumerate(tiles):
        row, column = divmod(i, 3)
        np.testing.assert_array_equal(
            image[row * height:(row + 1) * height, column * width:(column + 1) * width], tile)
    assert not np.array_equal(tiles[0], tiles[1])
    assert (image[height:, 2 * width:] == 255).all()
    many = make_vector_env("arena_strategy1", num_envs=RENDERED_WORLDS + 4,
                           render_mode="rgb_array")
    many.reset(seed=0)
    assert many.render().shape == (4 * height, 4 * width, 3)  # the first 16 worlds, 4 × 4


def test_a_pettingzoo_crowd_stepped_before_reset_asks_for_a_reset():
    """The arena's parallel crowd raised AttributeError ('no attribute crowd'), a type the docs
    do not name; it raises gymnasium's ResetNeeded, as every env here does."""
    from enn_traffic.envs.crowd import ArenaCrowdEnv

    crowd = ArenaCrowdEnv(shipped_scenario("arena_strategy1"), learners=2)
    with pytest.raises(gym.error.ResetNeeded):
        crowd.step({agent: np.zeros(2, np.float32) for agent in crowd.possible_agents})
