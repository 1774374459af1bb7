"""Stable-Baselines3 takes the environments as they are (issue 52): its checker passes every
id without a warning, the adapter gives SB3's end-of-life conventions, and the training
example of docs/envs.md runs as written."""

import re
import warnings
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

pytest.importorskip("stable_baselines3")
from stable_baselines3.common.env_checker import check_env  # noqa: E402

from enn_traffic.config.shipped import shipped_scenario  # noqa: E402
from enn_traffic.envs import REGISTERED, env_id, make_vector_env  # noqa: E402
from enn_traffic.envs.sb3 import sb3_vec_env  # noqa: E402

DOCS = Path(__file__).resolve().parents[2] / "docs" / "envs.md"


def _checked(name: str) -> list[str]:
    env = gym.make(env_id(name))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        check_env(env, warn=True)
    env.close()
    return [str(w.message) for w in caught]


@pytest.mark.parametrize("name", REGISTERED)
def test_sb3s_checker_passes_every_id_without_a_warning(name):
    assert _checked(name) == []


def test_a_lifes_end_gives_sb3_its_terminal_observation_and_truncation():
    """A capped life is truncated (SB3 bootstraps it), a collision is not; the episode's
    return is the fitness, and the terminal observation is the life's last one."""
    scenario = shipped_scenario("navigation_narrow").with_overrides(episode={"max_steps": 30})
    venv = sb3_vec_env(make_vector_env(scenario, num_envs=2))
    venv.reset()
    straight, circling = np.array([1.0, 1.0]), np.array([-1.0, 1.0])  # into a wall; capped
    ended: dict[int, tuple] = {}
    for _ in range(30):
        observation, reward, done, infos = venv.step(np.stack([straight, circling]))
        for i in np.flatnonzero(done):
            ended.setdefault(int(i), (infos[i], observation[i]))
    assert set(ended) == {0, 1} and reward.dtype == np.float32
    (hit, _), (capped, first_of_next) = ended[0], ended[1]
    assert capped["TimeLimit.truncated"]
    assert capped["episode"]["r"] == 30.0 == capped["episode"]["l"]
    assert capped["outcome"] == "capped"
    assert not hit["TimeLimit.truncated"] and hit["outcome"] == "collision"
    assert hit["episode"]["r"] == hit["episode"]["l"] < 30
    assert capped["terminal_observation"].shape == first_of_next.shape
    assert not np.array_equal(capped["terminal_observation"], first_of_next)


def test_the_docs_training_example_runs_as_written(capsys):
    """docs/envs.md's example, its budget cut to one rollout."""
    text = DOCS.read_text()
    block = re.search(r"<!-- example: sb3 -->\n```python\n(.*?)```", text, re.S)
    assert block, "docs/envs.md has lost its SB3 example"
    code = block.group(1)
    assert "total_timesteps=300_000" in code
    exec(compile(code.replace("total_timesteps=300_000", "total_timesteps=8_192"),
                 str(DOCS), "exec"), {})
    printed = capsys.readouterr().out
    mean = float(re.search(r"mean fitness: (\d+) steps lived", printed).group(1))
    assert mean > 0


def test_sb3s_evaluate_policy_reads_true_returns_under_vecnormalize():
    """The adapter writes what SB3's Monitor would, so evaluate_policy takes the lives'
    returns (the fitness: whole steps) rather than VecNormalize's scaled rewards."""
    import warnings

    from stable_baselines3 import PPO
    from stable_baselines3.common.evaluation import evaluate_policy
    from stable_baselines3.common.vec_env import VecNormalize

    venv = VecNormalize(sb3_vec_env(make_vector_env("arena_strategy1", num_envs=4)))
    model = PPO("MlpPolicy", venv, n_steps=64, batch_size=256, device="cpu", seed=1)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        returns, lengths = evaluate_policy(model, venv, n_eval_episodes=4,
                                           return_episode_rewards=True)
    assert returns == [float(n) for n in lengths] and min(lengths) > 1
