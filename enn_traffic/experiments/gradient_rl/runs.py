"""One run of each method, at most its budget of learner-steps: the GA (:func:`ga_run`), PPO and
SAC through Stable-Baselines3 (:func:`rl_run`); each chooses its controller among its
checkpoints on validation and scores it once on test."""

from __future__ import annotations

import copy
import os
import time
from dataclasses import dataclass

import numpy as np
import pandas as pd

from enn_traffic.config import Scenario
from enn_traffic.core import interrupts as stopping
from enn_traffic.core.cache import cache_folder, writable_folder
from enn_traffic.core.errors import InputError
from enn_traffic.envs.rangefinder import RangefinderVectorEnv, rangefinder_world
from enn_traffic.experiments.gradient_rl.policy import NumpyPolicy, numpy_actor
from enn_traffic.experiments.gradient_rl.protocol import (
    CHECKPOINTS,
    SEARCH,
    TEST_SITUATIONS,
    TRAINING_POOL_KEYS,
    VALIDATION_SITUATIONS,
    run_seed,
)
from enn_traffic.experiments.gradient_rl.scoring import (
    chromosome_fitness,
    held_out_keys,
    policy_fitness,
)
from enn_traffic.learning import ga
from enn_traffic.runs.controller import Controller


@dataclass(frozen=True)
class RunResult:
    """One run: its validation curve (learner_steps, wall_s, validation_fitness per
    candidate), the chosen candidate's row in it, that controller's fitness on each test
    situation (empty for a search run, which reads no test key), and the learner-steps it
    simulated in all (at most its budget: :data:`WITHIN_BUDGET`), the length of every life
    lived in training (the GA's individuals', the exploring policy's), and the chosen
    controller."""

    curve: pd.DataFrame
    chosen: int
    test_fitness: np.ndarray
    wall_s: float
    learner_steps: int
    training_lives: np.ndarray
    controller: Controller | NumpyPolicy  # the chosen one


def ga_run(scenario: Scenario, budget: int, seed: int, test: bool = True,
           settings: dict | None = None) -> RunResult:
    """The scenario's GA, seeded by ``seed``, for at most ``budget`` learner-steps: a
    generation that would end past the budget is not learned from (no method learns
    from more steps than its budget; only a first generation larger than the budget counts).
    A generation's champion is a candidate while the steps so far have passed more
    checkpoints than there are candidates (one a generation at most: after a generation that
    spans several checkpoints, the next ones are candidates too), and the last generation's;
    the candidates are scored on validation, the best of them on test. ``settings``: the
    scenario's ``[ga]`` keys to override (:data:`SEARCH`); another population size keeps the
    scenario's share of elites."""
    if settings:
        ga_settings = scenario.ga
        if "population_size" in settings and "elite_count" not in settings:
            share = ga_settings.elite_count / ga_settings.population_size
            settings = settings | {"elite_count": round(share * settings["population_size"])}
        scenario = scenario.with_overrides(ga=settings)
    world = rangefinder_world(scenario)
    params = scenario.ga
    rng = np.random.default_rng([scenario.seed, *run_seed(seed, budget).generate_state(2)])
    population = ga.initial_population(rng, params.population_size,
                                       world.spec.chromosome_length, params.init_range)
    run = ga.generations(ga.GAState(generation=0, population=population, rng=rng),
                         world.evaluate, params)
    every = max(1, budget // CHECKPOINTS)
    spent, began, rows, lives, candidates = 0, time.perf_counter(), [], [], []
    row = None  # the last generation learned from: (steps so far, wall, generation)
    while spent < budget:
        stopping.raise_if_requested()
        state, _, results = next(run)
        steps = int(results.steps.sum())
        if row is not None and spent + steps > budget:
            break
        spent += steps
        lives.append(results.steps.ravel())
        champion = state.champions[-1]
        row = (spent, time.perf_counter() - began, len(state.champions) - 1)
        if spent >= every * (len(rows) + 1):
            candidates.append(champion)
            rows.append(row)
    if rows[-1:] != [row]:  # the last generation is a candidate too
        candidates.append(champion)
        rows.append(row)
    wall = row[1]
    candidates = np.asarray(candidates)
    validation_keys, test_keys = held_out_keys(scenario)
    validation = chromosome_fitness(scenario, candidates, validation_keys,
                                    VALIDATION_SITUATIONS).mean(1)
    chosen = int(np.argmax(validation))
    tested = (chromosome_fitness(scenario, candidates[chosen:chosen + 1], test_keys,
                                 TEST_SITUATIONS)[0]
              if test else np.empty(0))
    curve = pd.DataFrame(rows, columns=["learner_steps", "wall_s", "generation"])
    controller = Controller.from_scenario(scenario, candidates[chosen], validation[chosen],
                                          int(curve["generation"].iloc[chosen]))
    return RunResult(curve.drop(columns="generation").assign(validation_fitness=validation),
                     chosen, tested, wall, spent, np.concatenate(lives), controller)


def rl_model(method: str, venv, settings: dict, seed: int):
    """An SB3 PPO or SAC model with ``settings`` (:data:`SEARCH`'s keys)."""
    from stable_baselines3 import PPO, SAC

    if method == "PPO":
        names = ("n_steps", "batch_size", "n_epochs", "gamma", "gae_lambda", "clip_range",
                 "ent_coef", "learning_rate")
        return PPO("MlpPolicy", venv, seed=seed, device="cpu", verbose=0,
                   policy_kwargs={"log_std_init": settings["log_std_init"]},
                   **{name: settings[name] for name in names})
    names = ("learning_rate", "buffer_size", "batch_size", "gamma", "tau", "train_freq",
             "gradient_steps", "learning_starts", "use_sde", "target_entropy")
    return SAC("MlpPolicy", venv, seed=seed, device="cpu", verbose=0,
               policy_kwargs={"log_std_init": settings["log_std_init"],
                              "net_arch": settings["net_arch"]},
               **{name: settings[name] for name in names})


def rl_run(scenario: Scenario, method: str, settings: dict, budget: int, seed: int,
           test: bool = True) -> RunResult:
    """PPO or SAC with ``settings`` for at most ``budget`` learner-steps (whole rollouts);
    its policy at every ``budget / CHECKPOINTS`` steps and at the end scored on validation,
    the best of them on test."""
    try:
        import torch
        from stable_baselines3.common.callbacks import BaseCallback
        from stable_baselines3.common.logger import Logger
        from stable_baselines3.common.vec_env import VecNormalize

        from enn_traffic.envs.sb3 import sb3_vec_env
    except ImportError:
        raise InputError(f"{method} needs the rl extra: pip install -e .[rl] "
                         "(docs/envs.md: a CPU-only torch)") from None
    torch.set_num_threads(1)
    # torch keeps a compiler cache folder that PPO's first update makes, by default
    # TMPDIR/torchinductor_<user>: it goes to the project's cache folder (a user's own
    # TORCHINDUCTOR_CACHE_DIR stands)
    os.environ.setdefault("TORCHINDUCTOR_CACHE_DIR", str(
        writable_folder(cache_folder() / "torchinductor", "torchinductor")))
    training = RangefinderVectorEnv(scenario, settings["n_envs"], situations=TRAINING_POOL_KEYS)
    venv = VecNormalize(sb3_vec_env(training),
                        norm_obs=True, norm_reward=settings["norm_reward"],
                        gamma=settings["gamma"])
    seed = int(run_seed(seed, budget).generate_state(1)[0] % 2**31)
    venv.seed(seed)
    model = rl_model(method, venv, settings, seed)
    # a logger of no outputs: SB3's own makes an empty SB3-<time> folder in TMPDIR per run
    model.set_logger(Logger(folder=None, output_formats=[]))
    every = max(1, budget // CHECKPOINTS)
    snapshots: list[tuple[int, float, NumpyPolicy]] = []
    lives: list[int] = []
    began = time.perf_counter()

    def snapshot() -> None:
        snapshots.append((model.num_timesteps, time.perf_counter() - began,
                          numpy_actor(model, copy.deepcopy(venv.obs_rms))))

    class Snapshots(BaseCallback):
        def _on_step(self) -> bool:
            stopping.raise_if_requested()
            lives.extend(info["episode"]["l"] for info in self.locals["infos"]
                         if "episode" in info)
            if self.num_timesteps >= every * (len(snapshots) + 1):
                snapshot()
            return True

    # Whole rollouts (PPO) or vector steps (SAC) within the budget, at least one: no method
    # learns from more steps than its budget.
    rollout = settings["n_envs"] * (settings["n_steps"] if method == "PPO" else 1)
    model.learn(total_timesteps=max(rollout, budget // rollout * rollout),
                callback=Snapshots())
    wall = time.perf_counter() - began
    if not snapshots or snapshots[-1][0] < model.num_timesteps:  # PPO's last update
        snapshot()
    validation_keys, test_keys = held_out_keys(scenario)
    validation = np.array([policy_fitness(scenario, act, validation_keys,
                                          VALIDATION_SITUATIONS).mean()
                           for _, _, act in snapshots])
    chosen = int(np.argmax(validation))
    tested = (policy_fitness(scenario, snapshots[chosen][2], test_keys, TEST_SITUATIONS)
              if test else np.empty(0))
    curve = pd.DataFrame([s[:2] for s in snapshots], columns=["learner_steps", "wall_s"])
    return RunResult(curve.assign(validation_fitness=validation), chosen, tested, wall,
                     int(model.num_timesteps), np.asarray(lives, dtype=np.int64),
                     snapshots[chosen][2])


def run_one(scenario: Scenario, method: str, setting: str, budget: int, seed: int,
            test: bool) -> RunResult:
    """One run in a worker process (one thread: the runs run side by side)."""
    import numba

    numba.set_num_threads(1)
    if method == "GA":
        return ga_run(scenario, budget, seed, test, SEARCH["GA"][setting])
    return rl_run(scenario, method, SEARCH[method][setting], budget, seed, test)
