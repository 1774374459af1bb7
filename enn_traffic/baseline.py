"""The paper's GA against gradient RL (PPO, Stable-Baselines3) at the same simulation budget
(docs/results.md, "The GA against PPO").

Both learn in the same worlds: the GA evaluates its populations on training keys (generation
``g`` draws key ``g``), PPO steps :class:`~enn_traffic.envs.rangefinder.RangefinderVectorEnv`
on training keys too. Their controllers are recorded along the way (the GA's best of each
generation by its training fitness; PPO's policy after each rollout past a checkpoint), with
the learner-steps simulated so far and the wall time; afterwards each is scored on the sealed
test situations that ``enn-traffic evaluate`` reads (:data:`enn_traffic.deploy.EVALUATION_KEY`),
the PPO policy acting deterministically (its mean action).

PPO runs with Stable-Baselines3's default settings, ``VecNormalize`` on observations and
rewards, and 16 worlds; nothing was tuned. It needs the ``rl`` extra
(``pip install -e .[rl]``).
"""

from __future__ import annotations

import copy
import time
from collections.abc import Iterator
from functools import partial
from pathlib import Path

import numpy as np
import pandas as pd

from enn_traffic.deploy import EVALUATION_KEY
from enn_traffic.envs.rangefinder import RangefinderVectorEnv, rangefinder_world
from enn_traffic.errors import InputError
from enn_traffic.evolution import ga
from enn_traffic.io import write_atomic
from enn_traffic.report.plots import save_figure
from enn_traffic.runner import ga_params
from enn_traffic.scenario import Scenario

TEST_SITUATIONS = 8  # situations of the test key each controller is scored on
PPO_WORLDS = 16


def test_scenario(scenario: Scenario) -> Scenario:
    """``scenario`` with the test situations' count of episodes per strategy."""
    strategies = len(scenario.traffic.strategy_list)
    return scenario.with_overrides(
        traffic={"episodes": max(1, TEST_SITUATIONS // max(strategies, 1))})


def ga_checkpoints(scenario: Scenario, budget: int, seed: int
                   ) -> Iterator[tuple[int, float, np.ndarray]]:
    """The GA run of ``scenario`` (its own settings, seeded by ``seed``) until ``budget``
    learner-steps are simulated: after each generation, (learner-steps so far, seconds so far,
    the generation's best chromosome by its training fitness)."""
    world = rangefinder_world(scenario)
    params = ga_params(scenario)
    rng = np.random.default_rng([scenario.seed, seed])
    population = ga.initial_population(rng, params.population_size,
                                       world.spec.chromosome_length, params.init_range)
    spent, began = 0, time.perf_counter()
    run = ga.generations(ga.GAState(generation=0, population=population, rng=rng),
                         world.evaluate, params)
    while spent < budget:
        state, _, results = next(run)
        spent += int(results.steps.sum())
        yield spent, time.perf_counter() - began, state.champions[-1].copy()


def ga_curve(scenario: Scenario, budget: int, seed: int) -> pd.DataFrame:
    """Test fitness of the GA's controllers against learner-steps and wall time."""
    rows = list(ga_checkpoints(scenario, budget, seed))
    world = rangefinder_world(test_scenario(scenario))
    champions = np.stack([row[2] for row in rows])
    scores = world.evaluate(champions, EVALUATION_KEY).fitness
    return pd.DataFrame({"method": "GA", "seed": seed,
                         "learner_steps": [row[0] for row in rows],
                         "wall_s": [row[1] for row in rows], "test_fitness": scores})


def sb3_vec_env(env: RangefinderVectorEnv):
    """A Stable-Baselines3 ``VecEnv`` over the compiled vector environment (SB3 keeps its
    own vector API: a list of infos, ``terminal_observation``)."""
    from stable_baselines3.common.vec_env import VecEnv

    class Adapter(VecEnv):
        def __init__(self):
            super().__init__(env.num_envs, env.single_observation_space,
                             env.single_action_space)
            self._actions = None

        def reset(self):
            observation, _ = env.reset(seed=self._seeds[0] if self._seeds else None)
            self._reset_seeds()
            return observation.astype(np.float32)

        def step_async(self, actions):
            self._actions = actions  # the environment clips them to its box

        def step_wait(self):
            observation, reward, terminated, truncated, info = env.step(self._actions)
            done = terminated | truncated
            infos = [{} for _ in range(self.num_envs)]
            for i in np.flatnonzero(done):
                infos[i] = {"terminal_observation": info["final_obs"][i].astype(np.float32),
                            "TimeLimit.truncated": bool(truncated[i])}
            return observation.astype(np.float32), reward.astype(np.float32), done, infos

        def close(self):
            env.close()

        def get_attr(self, name, indices=None):
            return [getattr(env, name)] * self.num_envs

        def set_attr(self, name, value, indices=None):
            setattr(env, name, value)

        def env_method(self, name, *args, indices=None, **kwargs):
            return [getattr(env, name)(*args, **kwargs)] * self.num_envs

        def env_is_wrapped(self, wrapper_class, indices=None):
            return [False] * self.num_envs

    return Adapter()


def ppo_curve(scenario: Scenario, budget: int, seed: int, checkpoints: int = 20
              ) -> pd.DataFrame:
    """Test fitness of PPO's policy against learner-steps and wall time."""
    try:
        import torch
        from stable_baselines3 import PPO
        from stable_baselines3.common.callbacks import BaseCallback
        from stable_baselines3.common.vec_env import VecNormalize
    except ImportError:
        raise InputError("PPO needs the rl extra: pip install -e .[rl]") from None
    torch.set_num_threads(1)
    venv = VecNormalize(sb3_vec_env(RangefinderVectorEnv(scenario, PPO_WORLDS)))
    venv.seed(seed)
    model = PPO("MlpPolicy", venv, seed=seed, device="cpu", verbose=0)
    every = budget // checkpoints
    snapshots = []

    class Snapshots(BaseCallback):
        def __init__(self):
            super().__init__()
            self.began = time.perf_counter()

        def _on_step(self) -> bool:
            return True

        def _on_rollout_end(self) -> None:
            if self.num_timesteps >= every * (len(snapshots) + 1):
                snapshots.append((self.num_timesteps, time.perf_counter() - self.began,
                                  copy.deepcopy(model.policy.state_dict()),
                                  copy.deepcopy(venv.obs_rms)))

    model.learn(total_timesteps=budget, callback=Snapshots())
    scores = []
    for _, _, weights, obs_rms in snapshots:
        model.policy.load_state_dict(weights)
        scores.append(policy_test_fitness(model, obs_rms, scenario))
    return pd.DataFrame({"method": "PPO", "seed": seed,
                         "learner_steps": [s[0] for s in snapshots],
                         "wall_s": [s[1] for s in snapshots], "test_fitness": scores})


def policy_test_fitness(model, obs_rms, scenario: Scenario) -> float:
    """Mean fitness of a policy (deterministic) over the test situations, each driven once."""
    tested = test_scenario(scenario)
    situations = len(tested.traffic.strategy_list) * tested.traffic.episodes
    env = RangefinderVectorEnv(tested, situations)
    observation, _ = env.reset(options={"keys": [EVALUATION_KEY]})
    fitness = np.full(situations, np.nan)
    while np.isnan(fitness).any():
        scaled = np.clip((observation - obs_rms.mean) / np.sqrt(obs_rms.var + 1e-8), -10, 10)
        action, _ = model.predict(scaled.astype(np.float32), deterministic=True)
        observation, _, terminated, truncated, info = env.step(action)
        for i in np.flatnonzero((terminated | truncated) & np.isnan(fitness)):
            fitness[i] = info["final_info"]["fitness"][i]
    return float(fitness.mean())


def compare(scenario: Scenario, budget: int, seeds: list[int], out: Path,
            methods: tuple[str, ...] = ("GA", "PPO")) -> pd.DataFrame:
    """Each method's curve for every seed, written to ``out/baseline.csv`` as they come,
    then ``out/baseline_summary.csv`` and the plot ``out/baseline.png``."""
    out.mkdir(parents=True, exist_ok=True)
    table = pd.DataFrame()
    for method in methods:
        for seed in seeds:
            curve = (ga_curve if method == "GA" else ppo_curve)(scenario, budget, seed)
            table = pd.concat([table, curve.assign(scenario=scenario.name)], ignore_index=True)
            write_atomic(out / "baseline.csv", partial(table.to_csv, index=False))
    write_atomic(out / "baseline_summary.csv", partial(summary(table).to_csv, index=False))
    plot(table, out / "baseline.png")
    return table


def plot(table: pd.DataFrame, path: Path) -> None:
    """Test fitness against learner-steps and against wall time, a line per run."""
    import matplotlib.pyplot as plt


    figure, axes = plt.subplots(1, 2, figsize=(10, 4), sharey=True)
    colours = {"GA": "tab:blue", "PPO": "tab:orange"}
    for (method, _), run in table.groupby(["method", "seed"]):
        for ax, x in zip(axes, ["learner_steps", "wall_s"], strict=True):
            ax.plot(run[x], run["test_fitness"], color=colours.get(method, "gray"), alpha=0.7,
                    label=method)
    axes[0].set_xlabel("learner-steps simulated")
    axes[1].set_xlabel("wall time (s)")
    axes[0].set_ylabel("test fitness (steps lived, mean of the test situations)")
    handles, labels = axes[0].get_legend_handles_labels()
    unique = dict(zip(labels, handles, strict=True))
    axes[0].legend(unique.values(), unique.keys())
    figure.suptitle(str(table["scenario"].iloc[0]) if len(table) else "")
    save_figure(figure, path)


def summary(table: pd.DataFrame) -> pd.DataFrame:
    """Per scenario and method: the last checkpoint's test fitness (mean and range over the
    seeds), learner-steps and wall time."""
    last = table.sort_values("learner_steps").groupby(["scenario", "method", "seed"]).tail(1)
    return last.groupby(["scenario", "method"]).agg(
        seeds=("seed", "nunique"), learner_steps=("learner_steps", "mean"),
        wall_s=("wall_s", "mean"), test_fitness_mean=("test_fitness", "mean"),
        test_fitness_min=("test_fitness", "min"), test_fitness_max=("test_fitness", "max"),
    ).reset_index()
