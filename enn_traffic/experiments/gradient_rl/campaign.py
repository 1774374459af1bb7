"""The paper's GA against gradient RL (PPO and SAC, Stable-Baselines3) at equal learner-steps
(docs/results.md, "The GA against gradient RL"; issues 52 and 65).

The protocol, the same for every method:

- its settings come from a search of twelve on validation keys (:data:`SEARCH`: the GA's
  mutation and population around the scenario's own, the paper's; PPO and SAC around RL Zoo's
  settings for BipedalWalker-v3, a continuous-control task read through rangefinders, their
  exploration included), one run each at :data:`SEARCH_BUDGET`; each scenario takes the
  setting whose run scored best on validation;
- it learns on training keys: the GA meets a new key each generation, PPO and SAC on
  :class:`~enn_traffic.envs.rangefinder.RangefinderVectorEnv` through
  :func:`~enn_traffic.envs.sb3.sb3_vec_env`, with ``VecNormalize`` on the observations, draw
  each life from a pool of :data:`TRAINING_POOL_KEYS` training keys; every run has its own
  random stream (:func:`run_seed`: a longer run is no continuation of a shorter one);
- its controllers along the way, one at every ``budget / CHECKPOINTS`` learner-steps and one
  at the end (the GA: the best of the generation that reached it, by training fitness, one a
  generation at most; PPO and SAC: the policy then, acting on its mean), are scored on
  :data:`VALIDATION_SITUATIONS` validation situations, and the best there is the run's
  controller, saved in ``controllers/``;
- that controller alone is scored on :data:`TEST_SITUATIONS` test situations sealed for this
  comparison (:data:`TEST_KEY`), read once, by the final configuration.

Validation and test situations are the scenario's own, except on a track without traffic
that starts at one pose (the narrow track, §5.1): there they start anywhere on the same track
(:func:`scoring_scenario`), every situation at a start of its own, none of the test starts a
validation start (:func:`held_out_keys`). A run is one (scenario, method, budget, seed); it is
written to ``comparison.csv`` as soon as it ends and skipped when already there, so the same
command continues an interrupted comparison.
"""

from __future__ import annotations

import copy
import json
import os
import time
from collections.abc import Callable
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from enn_traffic.config import Scenario, TrackConfig, scenario_digest
from enn_traffic.core import interrupts as stopping
from enn_traffic.core import keys
from enn_traffic.core.errors import InputError
from enn_traffic.core.io import write_atomic
from enn_traffic.core.progress import log, terminal
from enn_traffic.envs.rangefinder import RangefinderVectorEnv, rangefinder_world
from enn_traffic.learning import ga
from enn_traffic.report.stats import (
    above_share,
    bootstrap_interval,
    permutation_p,
    t_interval,
    welch_contrast,
)
from enn_traffic.runs.controller import Controller
from enn_traffic.runs.run import ga_params
from enn_traffic.sim.world import SituationResults

METHODS = ("GA", "PPO", "SAC")
RUN_KEYS = ["scenario", "method", "budget_steps", "seed"]  # a run's row in every CSV
# Keys of this comparison alone, never read by anything else (enn_traffic.core.keys). Its first
# two rounds read the test keys from FIRST_ROUND_TEST_KEY and SECOND_ROUND_TEST_KEY on; this,
# the third (issue 65), reads fresh ones, and no start of its validation situations is a
# start of its test situations (DISTINCT_STARTS).
FIRST_ROUND_TEST_KEY = keys.TEST.start + 520_000
SECOND_ROUND_TEST_KEY = keys.TEST.start + 530_000
VALIDATION_KEY = keys.VALIDATION.start + 540_000
TEST_KEY = keys.TEST.start + 540_000
VALIDATION_SITUATIONS = 128
TEST_SITUATIONS = 256
DISTINCT_STARTS = True
CHECKPOINTS = 20  # candidates along a run, every method alike (and one at its end)
TRAINING_POOL_KEYS = 4096  # PPO's and SAC's training keys: 16,384 arena situations
TUNING_SEED = 0  # the search's runs; the comparison's seeds are 1, 2, ...


@dataclass(frozen=True)
class Planned:
    """``seeds`` runs of ``method`` at ``budget_steps`` learner-steps each."""

    method: str
    budget_steps: int
    seeds: int


# Issue 65: ten independent seeds of every method at 1 M learner-steps, five of the GA and PPO
# at 5 M (their own seeds: :func:`run_seed`).
PLAN = (Planned("GA", 1_000_000, 10), Planned("PPO", 1_000_000, 10),
        Planned("SAC", 1_000_000, 10), Planned("GA", 5_000_000, 5),
        Planned("PPO", 5_000_000, 5))

# RL Zoo's BipedalWalker-v3 settings (rl-baselines3-zoo, hyperparams/ppo.yml and sac.yml: a
# continuous-control task read through rangefinders) as the search's start. Two changes make
# the budgets fit a 2-core machine (measured here, one thread per run): PPO's minibatch of 64
# trains at 1.9 k learner-steps/s (5 M steps: 45 min a seed), so the search's minibatches are
# 1,024; SAC's one gradient step per learner-step on its 400-300 network at 1 k steps/s, so
# SAC takes one per 32 (32 worlds, one step per vector step) on a 256-256 network.
ZOO_PPO = {"n_envs": 32, "n_steps": 2048, "batch_size": 1024, "n_epochs": 10, "gamma": 0.999,
           "gae_lambda": 0.95, "clip_range": 0.18, "ent_coef": 0.0, "learning_rate": 3e-4,
           "norm_reward": True, "log_std_init": 0.0}
ZOO_SAC = {"n_envs": 32, "learning_rate": 7.3e-4, "buffer_size": 300_000, "batch_size": 256,
           "gamma": 0.98, "tau": 0.02, "train_freq": 1, "gradient_steps": 1,
           "learning_starts": 10_000, "use_sde": True, "log_std_init": -3.0,
           "net_arch": [256, 256], "norm_reward": False, "target_entropy": "auto"}


def _grid(start: dict, name: Callable[..., str], **axes: tuple) -> dict[str, dict]:
    """Every combination of ``axes`` (key: values) over ``start``, named by ``name``."""
    import itertools

    return {name(**dict(zip(axes, values, strict=True))):
            start | dict(zip(axes, values, strict=True))
            for values in itertools.product(*axes.values())}


# The search (issue 65): twelve settings of every method, exploration among the axes (the
# GA's mutation, PPO's initial log-std, SAC's target entropy), one run each on validation
# keys at SEARCH_BUDGET. The GA's start is the scenario's own [ga] (the paper's).
SEARCH = {
    "GA": _grid({}, lambda mutation_probability, population_size:
                f"mutation {mutation_probability:g}, P {population_size}",
                mutation_probability=(0.02, 0.05, 0.1, 0.2), population_size=(50, 200, 800)),
    "PPO": _grid(ZOO_PPO, lambda log_std_init, gamma, n_steps:
                 f"log-std {log_std_init:g}, gamma {gamma:g}, rollouts {n_steps}",
                 log_std_init=(0.0, -1.0, -2.0), gamma=(0.99, 0.999), n_steps=(256, 2048)),
    "SAC": _grid(ZOO_SAC, lambda target_entropy, gamma, use_sde:
                 f"target entropy {target_entropy:g}, gamma {gamma:g}"
                 f"{', gSDE' if use_sde else ''}",
                 target_entropy=(-4.0, -2.0, -0.5), gamma=(0.98, 0.999), use_sde=(True, False)),
}
SEARCH_BUDGET = 300_000  # learner-steps of each search run, every method alike
# No method learns from steps past its budget: the GA's last generation, PPO's last rollout
# end within it (issue 65; before, both ended past it, a GA generation by up to 4 M steps).
WITHIN_BUDGET = True


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


# --- situations -----------------------------------------------------------------------------

def scoring_scenario(scenario: Scenario) -> Scenario:
    """The scenario validation and test situations are drawn from: ``scenario``, or, for a
    world without traffic and one start (every situation of it the same: the narrow track
    starts at one pose, §5.1), the same track started anywhere (every 5 m along its lanes,
    facing either way: ``track.start_anywhere``)."""
    track = scenario.track
    if (rangefinder_world(scenario).vehicles > 1 or not isinstance(track, TrackConfig)
            or track.start_anywhere or len(track.start_names) > 1):
        return scenario
    return scenario.with_overrides(track={"start_xy": None, "start_lane": None,
                                          "start_edge": None, "start_anywhere": True})


def situation_keys(scenario: Scenario, first_key: int, count: int, distinct: bool = False,
                   avoid: frozenset = frozenset()) -> list[int]:
    """The keys, from ``first_key`` on, whose situations (in order) hold ``count``. With
    ``distinct``, in a world that draws each situation's start from several, only keys whose
    starts are all new (to the keys before and to ``avoid``, a set of :func:`start_of`)."""
    world = rangefinder_world(scenario)
    per_key = len(world.situations(first_key))
    if not distinct or len(world.starts) == 1:
        return list(range(first_key, first_key + -(-count // per_key)))
    chosen, seen, key = [], set(avoid), first_key
    while len(chosen) * per_key < count:
        starts = [start_of(situation) for situation in world.situations(key)]
        if seen.isdisjoint(starts) and len(set(starts)) == len(starts):
            chosen.append(key)
            seen.update(starts)
        key += 1
        if key - first_key > 1000 * count:
            raise ValueError(f"{scenario.name}: too few starts for {count} situations that "
                             "share none")
    return chosen


def start_of(situation) -> tuple[float, float, float]:
    """The learner's start pose of a situation, rounded to the millimetre."""
    return tuple(np.round(situation.start[0], 3))


def held_out_keys(scenario: Scenario, protocol: dict | None = None
                  ) -> tuple[list[int], list[int]]:
    """The validation and the test keys of ``scenario``'s :func:`scoring_scenario` under
    ``protocol`` (:func:`protocol`, this round's by default): with distinct starts, the
    test keys avoid every validation start, and no start repeats within either."""
    protocol = protocol or globals()["protocol"]()
    scenario = scoring_scenario(scenario)
    distinct = bool(protocol.get("distinct_starts", False))
    validation = situation_keys(scenario, protocol["validation_key"],
                                protocol["validation_situations"], distinct)
    world = rangefinder_world(scenario)
    taken = frozenset(start_of(situation) for key in validation
                      for situation in world.situations(key)) if distinct else frozenset()
    test = situation_keys(scenario, protocol["test_key"], protocol["test_situations"],
                          distinct, taken)
    return validation, test


def chromosome_fitness(scenario: Scenario, chromosomes: np.ndarray, chosen_keys: list[int],
                       count: int) -> np.ndarray:
    """(C, count): each GA controller's fitness (steps lived, 0 for a spin) per situation of
    ``chosen_keys`` (in order, the first ``count``) of :func:`scoring_scenario`."""
    scenario = scoring_scenario(scenario)
    world = rangefinder_world(scenario)
    columns = []
    for key in chosen_keys:
        results = world.evaluate(chromosomes, key)
        columns.append(SituationResults.lifetime_fitness(results.steps, results.outcome))
    return np.concatenate(columns, axis=1)[:, :count]


def policy_lives(scenario: Scenario, act: Callable[[np.ndarray], np.ndarray],
                 keys: list[int], count: int | None = None, tail: int = 0,
                 observation_dtype: str = "float32") -> pd.DataFrame:
    """The first ``count`` situations of ``keys`` in ``scenario`` (in order; every one by
    default), each driven once by ``act`` (observations (N, B) → actions (N, 2)) through the
    vector environment: each life's steps, outcome and fitness (0 for a spin). A GA
    controller reads ``float64`` observations to live the lives :func:`chromosome_fitness`
    scores (its world's readings; ``float32`` ones part from them after hundreds of steps,
    :func:`observation_dtype`). With ``tail``,
    also where the learner went: ``distance`` (m) and ``tail_extent``, the larger of the x and
    y ranges of its last ``tail`` positions (m: a vehicle circling in place stays within its
    circle's diameter), and ``path``, its positions (steps, 2)."""
    if count is None:
        count = len(keys) * len(rangefinder_world(scenario).situations(keys[0]))
    env = RangefinderVectorEnv(scenario, count, observation_dtype=observation_dtype)
    observation, _ = env.reset(options={"keys": list(keys)})
    ended = {"steps": np.full(count, -1), "outcome": np.empty(count, dtype=object),
             "fitness": np.full(count, np.nan)}
    positions = []
    while (ended["steps"] < 0).any():
        if tail:
            positions.append(env.batch.worlds.pose[:, 0, :2].copy())
        observation, _, terminated, truncated, info = env.step(act(observation))
        for i in np.flatnonzero((terminated | truncated) & (ended["steps"] < 0)):
            for column, values in ended.items():
                values[i] = info["final_info"][column][i]
    table = pd.DataFrame(ended)
    if tail:
        path = np.stack(positions, axis=1)  # (count, steps, 2)
        lived = [path[i, :max(1, steps)] for i, steps in enumerate(ended["steps"])]
        table["distance"] = [np.linalg.norm(np.diff(p, axis=0), axis=1).sum() for p in lived]
        table["tail_extent"] = [np.ptp(p[-tail:], axis=0).max() for p in lived]
        table["path"] = lived
    return table


def policy_fitness(scenario: Scenario, act: Callable[[np.ndarray], np.ndarray],
                   chosen_keys: list[int], count: int) -> np.ndarray:
    """(count,): a policy's fitness per situation of ``chosen_keys`` (in order, the first
    ``count``) of :func:`scoring_scenario` (:func:`policy_lives`)."""
    return policy_lives(scoring_scenario(scenario), act, chosen_keys, count)[
        "fitness"].to_numpy()


def observation_dtype(method: str) -> str:
    """The observations a method's controllers are scored on in the comparison: the GA's
    world's ``float64`` readings (:func:`chromosome_fitness`), the vector environment's
    ``float32`` ones for the policies it trained."""
    return "float64" if method == "GA" else "float32"


# --- the GA ---------------------------------------------------------------------------------

def run_seed(seed: int, budget: int) -> np.random.SeedSequence:
    """A run's own random stream: from its seed and its budget, so that a run at 5 M steps is
    no continuation of the same seed's run at 1 M (issue 65)."""
    return np.random.SeedSequence([seed, budget])


def ga_run(scenario: Scenario, budget: int, seed: int, test: bool = True,
           settings: dict | None = None) -> RunResult:
    """The scenario's GA, seeded by ``seed``, for at most ``budget`` learner-steps: a
    generation that would end past the budget is not learned from (issue 65: no method learns
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
    params = ga_params(scenario)
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


# --- PPO and SAC ----------------------------------------------------------------------------

@dataclass(eq=False)  # arrays: compare with numpy
class NumpyPolicy:
    """A policy's deterministic action (its mean, squashed for SAC) as plain numpy, with
    ``VecNormalize``'s observation scaling: scoring thousands of steps without torch's
    per-call cost, and a controller saved as arrays (:meth:`save`, :meth:`load`).
    ``layers``: ("linear", weight (in, out), bias), ("clip", low, high), ("Tanh" or "ReLU",
    None, None), in order."""

    layers: list[tuple[str, Any, Any]]
    mean: np.ndarray
    scale: np.ndarray
    squash: bool
    clip_obs: float = 10.0

    def __call__(self, observation: np.ndarray) -> np.ndarray:
        x = np.clip((observation - self.mean) / self.scale, -self.clip_obs, self.clip_obs)
        for kind, a, b in self.layers:
            x = (x @ a + b if kind == "linear" else np.clip(x, a, b) if kind == "clip"
                 else np.tanh(x) if kind == "Tanh" else np.maximum(x, 0.0))
        return np.tanh(x) if self.squash else np.clip(x, -1.0, 1.0)

    def save(self, path: Path) -> None:
        arrays = {"mean": self.mean, "scale": self.scale, "squash": self.squash,
                  "clip_obs": self.clip_obs,
                  "kinds": np.array([kind for kind, _, _ in self.layers])}
        for i, (_, a, b) in enumerate(self.layers):
            if a is not None:
                arrays[f"a{i}"], arrays[f"b{i}"] = a, b
        write_atomic(path, lambda handle: np.savez(handle, **arrays), binary=True)

    @classmethod
    def load(cls, path: Path) -> NumpyPolicy:
        with np.load(path) as data:
            layers = [(str(kind), *((data[f"a{i}"], data[f"b{i}"]) if f"a{i}" in data.files
                                    else (None, None)))
                      for i, kind in enumerate(data["kinds"])]
            layers = [(kind, float(a), float(b)) if kind == "clip" else (kind, a, b)
                      for kind, a, b in layers]
            return cls(layers, data["mean"], data["scale"], bool(data["squash"]),
                       float(data["clip_obs"]))


def numpy_actor(model, obs_rms, clip_obs: float = 10.0) -> NumpyPolicy:
    """The SB3 PPO or SAC ``model``'s actor with ``obs_rms`` as a :class:`NumpyPolicy`."""
    import torch.nn as nn

    if hasattr(model.policy, "actor"):  # SAC
        layers = [*model.policy.actor.latent_pi, model.policy.actor.mu]
        squash = True
    else:  # PPO
        layers = [*model.policy.mlp_extractor.policy_net, model.policy.action_net]
        squash = False
    steps = []
    for layer in _flat(layers):
        if isinstance(layer, nn.Linear):
            steps.append(("linear", layer.weight.detach().numpy().T.copy(),
                          layer.bias.detach().numpy().copy()))
        elif isinstance(layer, nn.Hardtanh):  # SAC's clipped mean under gSDE
            steps.append(("clip", float(layer.min_val), float(layer.max_val)))
        elif isinstance(layer, (nn.Tanh, nn.ReLU)):
            steps.append((type(layer).__name__, None, None))
        else:
            raise TypeError(f"numpy_actor: no numpy form for {type(layer).__name__}")
    return NumpyPolicy(steps, obs_rms.mean.copy(), np.sqrt(obs_rms.var + 1e-8), squash,
                       clip_obs)


def _flat(modules) -> list:
    """``modules`` with every ``nn.Sequential`` opened, in order."""
    import torch.nn as nn

    return [leaf for module in modules for leaf in
            (_flat(module) if isinstance(module, nn.Sequential) else [module])]


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
        from stable_baselines3.common.vec_env import VecNormalize

        from enn_traffic.envs.sb3 import sb3_vec_env
    except ImportError:
        raise InputError(f"{method} needs the rl extra: pip install -e .[rl] "
                         "(docs/envs.md: a CPU-only torch)") from None
    torch.set_num_threads(1)
    training = RangefinderVectorEnv(scenario, settings["n_envs"], situations=TRAINING_POOL_KEYS)
    venv = VecNormalize(sb3_vec_env(training),
                        norm_obs=True, norm_reward=settings["norm_reward"],
                        gamma=settings["gamma"])
    seed = int(run_seed(seed, budget).generate_state(1)[0] % 2**31)
    venv.seed(seed)
    model = rl_model(method, venv, settings, seed)
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
    # learns from more steps than its budget (issue 65).
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


# --- the comparison -------------------------------------------------------------------------

def run_one(scenario: Scenario, method: str, setting: str, budget: int, seed: int,
            test: bool) -> RunResult:
    """One run in a worker process (one thread: the runs run side by side)."""
    import numba

    numba.set_num_threads(1)
    if method == "GA":
        return ga_run(scenario, budget, seed, test, SEARCH["GA"][setting])
    return rl_run(scenario, method, SEARCH[method][setting], budget, seed, test)


def _read(path: Path) -> pd.DataFrame:
    return pd.read_csv(path) if path.exists() else pd.DataFrame()


def _append(path: Path, rows: pd.DataFrame, run: dict | None = None) -> None:
    """``rows`` added to the CSV at ``path``, replacing the rows of the same ``run`` (left
    there by a run interrupted before its comparison row)."""
    table = _read(path)
    if run and not table.empty:
        table = table[~np.logical_and.reduce([table[k] == v for k, v in run.items()])]
    table = pd.concat([table, rows], ignore_index=True)
    write_atomic(path, partial(table.to_csv, index=False))


def _jobs(jobs: list[tuple], workers: int, done: Callable[[tuple, RunResult], None],
          progress: bool) -> None:
    """Run ``jobs`` (run_one's arguments) on ``workers`` spawned processes (numba's threads
    do not survive a fork), handing each result to ``done`` as it ends."""
    import multiprocessing

    from tqdm import tqdm

    from enn_traffic.learning.evaluators import quiet_worker, sigint_held_back, stop_pool

    bar = tqdm(file=terminal(),
               total=len(jobs), desc="runs", unit="run", disable=not progress or not jobs)
    if workers == 1 or len(jobs) <= 1:
        for job in jobs:
            stopping.raise_if_requested()
            done(job, run_one(*job))
            bar.update()
        bar.close()
        return
    pool = ProcessPoolExecutor(workers, mp_context=multiprocessing.get_context("spawn"),
                               initializer=quiet_worker, initargs=(os.getpid(),))
    try:
        with sigint_held_back():
            futures = {pool.submit(run_one, *job): job for job in jobs}
        for future in as_completed(futures):
            stopping.raise_if_requested()
            done(futures[future], future.result())
            bar.update()
    except BaseException:  # Ctrl-C, SIGTERM: the runs end now; finished ones are written
        stop_pool(pool)
        raise
    pool.shutdown()
    bar.close()


def tune(scenarios: list[Scenario], out: Path, methods: tuple[str, ...], workers: int,
         progress: bool = True, budget: int = SEARCH_BUDGET) -> pd.DataFrame:
    """Every setting of :data:`SEARCH` for ``methods``, one run each per scenario on
    validation keys at ``budget`` learner-steps, into ``out/tuning.csv`` (a setting already
    there is not run again)."""
    path = out / "tuning.csv"
    have = _read(path)
    done_before = set() if have.empty else set(
        zip(have["scenario"], have["method"], have["setting"], strict=True))
    jobs = [(scenario, method, setting, budget, TUNING_SEED, False)
            for scenario in scenarios for method in methods
            for setting in SEARCH[method] if (scenario.name, method, setting) not in done_before]

    def record(job: tuple, result: RunResult) -> None:
        scenario, method, setting, budget, seed, _ = job
        best = result.curve.iloc[result.chosen]
        _append(path, pd.DataFrame([{
            "scenario": scenario.name, "method": method, "setting": setting,
            "budget_steps": budget, "seed": seed, "learner_steps": result.learner_steps,
            "validation_situations": VALIDATION_SITUATIONS,
            "validation_fitness": best["validation_fitness"],
            "chosen_at_steps": int(best["learner_steps"]), "wall_s": result.wall_s}]))

    _jobs(sorted(jobs, key=_cost, reverse=True), workers, record, progress)
    return _read(path)


def _cost(job: tuple) -> float:
    """A run's rough cost, to start the longest first: SAC's step is dearest, the GA's
    cheapest."""
    _, method, _, budget, _, _ = job
    return budget * {"GA": 0.2, "PPO": 1.0, "SAC": 5.0}[method]


def chosen_setting(tuning: pd.DataFrame, scenario: str, method: str) -> str:
    """The setting of ``method`` whose search run scored best on validation in ``scenario``
    (of equal scores, the one :data:`SEARCH` lists first)."""
    rows = tuning[(tuning["scenario"] == scenario) & (tuning["method"] == method)]
    if rows.empty:
        raise InputError(f"no search run of {method} for {scenario}: run the search first")
    order = list(SEARCH[method])  # a tie goes to the setting listed first, not the CSV's order
    rows = rows.assign(listed=rows["setting"].map(order.index))
    return str(rows.sort_values(["validation_fitness", "listed"],
                                ascending=[False, True]).iloc[0]["setting"])


def compare(scenarios: list[Scenario], out: Path, plan: tuple[Planned, ...] = PLAN,
            workers: int = 1, progress: bool = True,
            search_budget: int = SEARCH_BUDGET) -> pd.DataFrame:
    """The search, then every planned run of each scenario not yet in ``out/comparison.csv``:
    its row there, its validation curve in ``curves.csv``, its test situations in
    ``situations.csv``; then the lives lived in training (:func:`training_lives`), the
    summary and the plot (:func:`write_summary`)."""
    out.mkdir(parents=True, exist_ok=True)
    check_protocol(out)
    check_scenarios(out, scenarios)
    methods = tuple(dict.fromkeys(p.method for p in plan))
    budget = min([search_budget] + [p.budget_steps for p in plan])
    tuning = tune(scenarios, out, methods, workers, progress, budget)
    have = _read(out / "comparison.csv")
    done_before = set() if have.empty else set(
        have[RUN_KEYS].itertuples(index=False, name=None))
    jobs = [(scenario, p.method, chosen_setting(tuning, scenario.name, p.method),
             p.budget_steps, seed, True)
            for scenario in scenarios for p in plan for seed in range(1, p.seeds + 1)
            if (scenario.name, p.method, p.budget_steps, seed) not in done_before]

    for scenario, method, setting, budget, _, _ in jobs:
        if method == "PPO":
            rollout = SEARCH["PPO"][setting]["n_steps"] * SEARCH["PPO"][setting]["n_envs"]
            if budget < 4 * rollout:
                log.warning(f"{scenario.name}: PPO's setting {setting!r} learns in rollouts of "
                            f"{rollout:,} steps: a budget of {budget:,} gives "
                            f"{-(-budget // rollout)} of them")

    def record(job: tuple, result: RunResult) -> None:
        scenario, method, setting, budget, seed, _ = job
        run = {"scenario": scenario.name, "method": method, "budget_steps": budget,
               "seed": seed}
        best = result.curve.iloc[result.chosen]
        fitness = result.test_fitness
        low, high = bootstrap_interval(fitness, np.random.default_rng(seed))
        # the rest first: a run is done once its comparison row is written
        save_controller(out, job, result)
        if _lives_run(plan, method, budget, seed):
            _record_lives(out / "training_lives.csv", job, result)
        _append(out / "situations.csv", pd.DataFrame(
            {**run, "situation": np.arange(len(fitness)), "test_fitness": fitness}), run)
        _append(out / "curves.csv", result.curve.assign(**run), run)
        _append(out / "comparison.csv", pd.DataFrame([{
            **run, "setting": setting, "spin_variance": scenario.episode.spin_variance,
            "learner_steps": result.learner_steps,
            "test_situations": len(fitness), "test_fitness": fitness.mean(),
            "test_fitness_low": low, "test_fitness_high": high,
            "validation_fitness": best["validation_fitness"],
            "chosen_at_steps": int(best["learner_steps"]), "wall_s": result.wall_s}]))

    _jobs(sorted(jobs, key=_cost, reverse=True), workers, record, progress)
    training_lives(scenarios, out, plan, workers, progress)  # rows a past run left out
    write_summary(out)
    return _read(out / "comparison.csv")


def protocol() -> dict[str, int]:
    """What makes a run's scores comparable with another's: its keys and counts."""
    return {"validation_key": VALIDATION_KEY, "test_key": TEST_KEY,
            "validation_situations": VALIDATION_SITUATIONS,
            "test_situations": TEST_SITUATIONS, "checkpoints": CHECKPOINTS,
            "training_pool_keys": TRAINING_POOL_KEYS, "distinct_starts": DISTINCT_STARTS,
            "search_budget_steps": SEARCH_BUDGET, "within_budget": WITHIN_BUDGET}


def check_protocol(out: Path) -> None:
    """``out/protocol.json`` written for a new folder; a folder of runs made under another
    protocol (or before one was recorded) refused, since the same command would mix their
    rows with new ones."""
    path = out / "protocol.json"
    if path.is_file():
        try:
            theirs = json.loads(path.read_text())
        except (OSError, ValueError) as exc:
            raise InputError(f"not readable ({exc})", path) from None
        if theirs != protocol():
            changed = ", ".join(sorted(k for k in protocol() if theirs.get(k) != protocol()[k]))
            raise InputError(f"its runs were made with another {changed}: give another --out",
                             path)
        return
    if any((out / name).exists() for name in ("tuning.csv", "comparison.csv")):
        raise InputError("holds runs but no protocol.json (made by an older enn-traffic): "
                         "give another --out", out)
    write_atomic(path, lambda handle: json.dump(protocol(), handle, indent=1))


def check_scenarios(out: Path, scenarios: list[Scenario]) -> None:
    """Runs are found in ``out`` by their scenario's name: ``out/scenarios.json`` keeps, for
    each name, a digest of the scenario's settings and of every file it reads
    (:func:`~enn_traffic.config.scenario_digest`), and a scenario of a known name with
    another digest is refused (another scenario of the same name would reuse the first one's
    runs). A name new to the folder is added; a folder of runs made before the file was kept
    takes the digests of the scenarios it is given now."""
    path = out / "scenarios.json"
    known: dict[str, str] = {}
    if path.is_file():
        try:
            known = dict(json.loads(path.read_text()))
        except (OSError, ValueError, TypeError) as exc:
            raise InputError(f"not readable ({exc})", path) from None
    for scenario in scenarios:
        digest = scenario_digest(scenario)
        if known.setdefault(scenario.name, digest) != digest:
            raise InputError(
                f"the runs of {scenario.name!r} here were made with other settings or files "
                f"than {scenario.source or 'this scenario'}'s: give another --out, or the "
                "scenario another name", path, scenario.name)
    write_atomic(path, lambda handle: json.dump(known, handle, indent=1, sort_keys=True))


def controller_path(out: Path, scenario: str, method: str, budget: int, seed: int) -> Path:
    """Where a comparison run's chosen controller is saved."""
    return out / "controllers" / f"{scenario}-{method}-{budget}-{seed}.npz"


def save_controller(out: Path, job: tuple, result: RunResult) -> None:
    """A run's chosen controller: the GA's as a controller file every command reads
    (``enn-traffic evaluate``, ``deploy``), PPO's and SAC's as a :class:`NumpyPolicy`."""
    scenario, method, _, budget, seed, _ = job
    path = controller_path(out, scenario.name, method, budget, seed)
    path.parent.mkdir(parents=True, exist_ok=True)
    result.controller.save(path)


def training_lives(scenarios: list[Scenario], out: Path, plan: tuple[Planned, ...],
                   workers: int = 1, progress: bool = True) -> pd.DataFrame:
    """How long the lives lived in training were: one run of each method (seed 1, its first
    budget in ``plan``, the comparison's setting) with every life recorded, into
    ``out/training_lives.csv``. :func:`compare` writes these rows as it makes those runs; a
    run made again here is one whose row is missing. Training keys only: this reads no
    validation or test situation beyond the run's own choice."""
    path = out / "training_lives.csv"
    tuning, have = _read(out / "tuning.csv"), _read(path)
    done_before = set() if have.empty else set(zip(have["scenario"], have["method"],
                                                   strict=True))
    jobs = [(scenario, p.method, chosen_setting(tuning, scenario.name, p.method),
             p.budget_steps, 1, False)
            for scenario in scenarios for p in plan
            if _lives_run(plan, p.method, p.budget_steps, 1)
            and (scenario.name, p.method) not in done_before]

    _jobs(jobs, workers, partial(_record_lives, path), progress)
    return _read(path)


def _lives_run(plan: tuple[Planned, ...], method: str, budget: int, seed: int) -> bool:
    """Is this run the one whose training lives ``training_lives.csv`` holds: seed 1 at
    the method's first budget in ``plan``?"""
    first = next(p.budget_steps for p in plan if p.method == method)
    return seed == 1 and budget == first


def _record_lives(path: Path, job: tuple, result: RunResult) -> None:
    """A run's training lives, summarised as a row of ``training_lives.csv``."""
    scenario, method, setting, budget, seed, _ = job
    lived = result.training_lives
    _append(path, pd.DataFrame([{
        "scenario": scenario.name, "method": method, "setting": setting,
        "budget_steps": budget, "seed": seed, "lives": len(lived),
        "median_life": float(np.median(lived)), "longest_life": int(lived.max()),
        "lives_over_100": int((lived > 100).sum()),
        "lives_over_1000": int((lived > 1000).sum())}]),
        {"scenario": scenario.name, "method": method})


def summary(comparison: pd.DataFrame, curves: pd.DataFrame) -> pd.DataFrame:
    """Per scenario, method and budget: the seeds' mean test fitness with its 90% t interval
    over the seeds, the learner-steps and wall time, how many candidates each run chose
    among (mean), how many runs chose their last one, and how far the chosen controllers'
    validation scores stood above their test scores (the choice's optimism)."""
    per_run = curves.groupby(RUN_KEYS)["learner_steps"].agg(["size", "max"])
    runs_of = comparison.join(per_run, on=RUN_KEYS)
    rows = []
    for (name, method, budget), runs in runs_of.groupby(["scenario", "method", "budget_steps"]):
        low, high = t_interval(runs["test_fitness"].to_numpy())
        rows.append({
            "scenario": name, "method": method, "budget_steps": budget, "seeds": len(runs),
            "test_situations": int(runs["test_situations"].iloc[0]),
            "test_fitness": runs["test_fitness"].mean(), "seeds_low": low, "seeds_high": high,
            "learner_steps": runs["learner_steps"].mean(), "wall_s": runs["wall_s"].mean(),
            "candidates": runs["size"].mean(),
            "last_chosen": int((runs["chosen_at_steps"] == runs["max"]).sum()),
            "validation_minus_test": (runs["validation_fitness"] - runs["test_fitness"]).mean()})
    return pd.DataFrame(rows)


def differences(comparison: pd.DataFrame, level: float = 0.9) -> pd.DataFrame:
    """PPO's and SAC's test fitness minus the GA's, at every pair of budgets in a scenario:
    the difference of the seeds' means with its Welch t interval (the seeds' spread, the
    main spread of RL, counts; each seed's score is the mean over the same situations; two
    groups without spread give a point), the share of (seed, GA seed) pairs in which the
    method's scores higher (:func:`above_share`), its exact permutation p-value (no normal
    shape assumed: scores pile at the step cap), and, for the family of a scenario's comparisons
    (``family`` of them), Holm's adjusted p-value and Bonferroni's simultaneous interval
    (each at level 1 − (1 − ``level``) / family, so that all of a scenario's intervals hold
    together)."""
    rows = []
    for (name, method, budget), runs in comparison.groupby(
            ["scenario", "method", "budget_steps"]):
        if method == "GA":
            continue
        ga = comparison[(comparison["scenario"] == name) & (comparison["method"] == "GA")]
        for ga_budget, theirs in ga.groupby("budget_steps"):
            mine, other = runs["test_fitness"].to_numpy(), theirs["test_fitness"].to_numpy()
            rows.append({"scenario": name, "method": method, "budget_steps": budget,
                         "ga_budget_steps": ga_budget, "seeds": len(mine),
                         "ga_seeds": len(other), "minus_ga": mine.mean() - other.mean(),
                         "above_ga": above_share(mine, other),
                         "mine_values": mine, "ga_values": other})
    table = pd.DataFrame(rows)
    if table.empty:
        return pd.DataFrame(columns=[
            "scenario", "method", "budget_steps", "ga_budget_steps", "seeds", "ga_seeds",
            "minus_ga", "above_ga", "minus_ga_low", "minus_ga_high", "p_value",
            "minus_ga_low_simultaneous", "minus_ga_high_simultaneous", "family", "p_holm"])
    family = table.groupby("scenario")["method"].transform("size")
    columns = {"minus_ga_low": [], "minus_ga_high": [], "p_value": [],
               "minus_ga_low_simultaneous": [], "minus_ga_high_simultaneous": []}
    for row, size in zip(table.itertuples(), family, strict=True):
        groups = [row.mine_values, row.ga_values]
        _, low, high = welch_contrast(groups, [1, -1], level)
        _, low_together, high_together = welch_contrast(groups, [1, -1],
                                                        1 - (1 - level) / size)
        p_value = permutation_p(*groups) if min(map(len, groups)) > 1 else np.nan
        values = [low, high, p_value, low_together, high_together]
        for column, value in zip(columns, values, strict=True):
            columns[column].append(float(value))
    table = table.drop(columns=["mine_values", "ga_values"]).assign(**columns, family=family)
    table["p_holm"] = table.groupby("scenario")["p_value"].transform(holm)
    return table


def holm(p_values: pd.Series) -> pd.Series:
    """Holm's step-down adjustment of a family of p-values (missing ones left out of the
    family and missing in the result)."""
    known = p_values.dropna().sort_values()
    size = len(known)
    adjusted = np.maximum.accumulate((size - np.arange(size)) * known.to_numpy())
    return pd.Series(np.minimum(adjusted, 1.0), index=known.index).reindex(p_values.index)


# Scenarios that differ in their spin rule alone (issue 65): the paper's first, the second
# rule (enn_traffic.experiments.gradient_rl.spin_rule) after it.
RULE_PAIRS = (("navigation_narrow", "navigation_narrow_spin40"),)


def rule_changes(comparison: pd.DataFrame, pairs: tuple = RULE_PAIRS,
                 level: float = 0.9) -> pd.DataFrame:
    """How each method's gap to the GA (its seeds' mean test fitness minus the GA's, at every
    pair of budgets) changes from the paper's spin rule to the second: both gaps; the share
    of (method seed, GA seed) pairs in which the method scores higher under each rule (a
    measure no rescaling of fitness changes, where the rules' fitness ranges differ); and
    the change, (method − GA) under the second minus (method − GA) under the paper's, with
    its Welch–Satterthwaite t interval over the four groups of seeds and Bonferroni's
    simultaneous one for a pair's ``family`` of changes. The two scenarios share their seed
    (same ``seed``, same run streams), so seed s starts alike under both rules; the interval
    treats the groups as independent, which is conservative if that pairing makes a seed's
    scores under the two rules agree."""
    scores = {key: runs["test_fitness"].to_numpy() for key, runs in
              comparison.groupby(["scenario", "method", "budget_steps"])}
    weights = [1, -1, -1, 1]  # (method − GA) under the second rule, minus under the paper's
    rows = []
    for paper_rule, second in pairs:
        budgets = comparison[comparison["scenario"].isin([paper_rule, second])].groupby(
            "method")["budget_steps"].unique()
        found = [(method, budget, ga_budget, [
                     scores.get((second, method, budget), []),
                     scores.get((second, "GA", ga_budget), []),
                     scores.get((paper_rule, method, budget), []),
                     scores.get((paper_rule, "GA", ga_budget), [])])
                 for method in METHODS if method != "GA" and method in budgets
                 for budget in sorted(budgets[method])
                 for ga_budget in sorted(budgets.get("GA", []))]
        found = [f for f in found if min(map(len, f[3])) > 0]
        together = 1 - (1 - level) / max(1, len(found))
        for method, budget, ga_budget, groups in found:
            change, low, high = welch_contrast(groups, weights, level)
            _, low_together, high_together = welch_contrast(groups, weights, together)
            rows.append({
                "paper_rule": paper_rule, "second_rule": second, "method": method,
                "budget_steps": budget, "ga_budget_steps": ga_budget,
                "minus_ga_paper_rule": groups[2].mean() - groups[3].mean(),
                "minus_ga_second_rule": groups[0].mean() - groups[1].mean(),
                "above_ga_paper_rule": above_share(groups[2], groups[3]),
                "above_ga_second_rule": above_share(groups[0], groups[1]),
                "change": change, "change_low": low, "change_high": high,
                "change_low_simultaneous": low_together,
                "change_high_simultaneous": high_together,
                "family": len(found)})
    return pd.DataFrame(rows, columns=[
        "paper_rule", "second_rule", "method", "budget_steps", "ga_budget_steps",
        "minus_ga_paper_rule", "minus_ga_second_rule", "above_ga_paper_rule",
        "above_ga_second_rule", "change", "change_low", "change_high",
        "change_low_simultaneous", "change_high_simultaneous", "family"])


def write_summary(out: Path) -> pd.DataFrame:
    """``out/comparison_summary.csv``, ``comparison_differences.csv``,
    ``comparison_rules.csv`` and ``comparison.png`` from the runs' CSVs."""
    runs = _read(out / "comparison.csv")
    table = summary(runs, _read(out / "curves.csv"))
    write_atomic(out / "comparison_summary.csv", partial(table.to_csv, index=False))
    write_atomic(out / "comparison_differences.csv",
                 partial(differences(runs).to_csv, index=False))
    write_atomic(out / "comparison_rules.csv", partial(rule_changes(runs).to_csv, index=False))
    plot(_read(out / "curves.csv"), _read(out / "comparison.csv"), out / "comparison.png")
    return table


COLOURS = {"GA": "tab:blue", "PPO": "tab:orange", "SAC": "tab:green"}


def plot(curves: pd.DataFrame, comparison: pd.DataFrame, path: Path) -> None:
    """Per scenario: the validation fitness of each run's controllers against learner-steps
    (a line per run, the longest budgets), and each method's test fitness per run."""
    import matplotlib.pyplot as plt

    from enn_traffic.report.plots import save_figure

    scenarios = sorted(comparison["scenario"].unique())
    figure, axes = plt.subplots(len(scenarios), 2, figsize=(12, 4.4 * len(scenarios)),
                                squeeze=False, gridspec_kw={"wspace": 0.35, "hspace": 0.35})
    for row, name in zip(axes, scenarios, strict=True):
        mine = curves[curves["scenario"] == name]
        for (method, budget, _), run in mine.groupby(["method", "budget_steps", "seed"]):
            row[0].plot(run["learner_steps"], run["validation_fitness"],
                        color=COLOURS.get(method, "gray"), alpha=0.5,
                        linestyle="-" if budget > 1_000_000 else ":",
                        label=f"{method}, {budget / 1e6:g} M")
        row[0].set_xscale("log")
        row[0].set_xlabel("learner-steps simulated")
        row[0].set_ylabel(f"{name}\nvalidation fitness (steps lived)")
        handles, labels = row[0].get_legend_handles_labels()
        unique = dict(zip(labels, handles, strict=True))
        row[0].legend(unique.values(), unique.keys(), fontsize=7)
        runs = comparison[comparison["scenario"] == name].sort_values(
            ["method", "budget_steps"])
        groups = list(runs.groupby(["method", "budget_steps"], sort=False))
        for x, ((method, _), group) in enumerate(groups):
            row[1].errorbar(np.full(len(group), x) + np.linspace(-0.2, 0.2, len(group)),
                            group["test_fitness"],
                            yerr=[group["test_fitness"] - group["test_fitness_low"],
                                  group["test_fitness_high"] - group["test_fitness"]],
                            fmt="o", color=COLOURS.get(method, "gray"), capsize=2,
                            alpha=0.6)
            mean = group["test_fitness"].mean()
            low, high = t_interval(group["test_fitness"].to_numpy())
            low = max(low, 0.0)  # no fitness is below 0 (the tables cut alike)
            row[1].errorbar([x + 0.3], [mean], yerr=[[mean - low], [high - mean]], fmt="D",
                            color="black", capsize=3)
        row[1].set_xticks(range(len(groups)),
                          [f"{m}\n{b / 1e6:g} M" for (m, b), _ in groups])
        row[1].set_ylim(bottom=0)
        row[1].set_ylabel("test fitness (steps lived)")
        row[1].set_title("each run: 90% interval over its test situations; black: the "
                         "seeds' mean, 90% t interval", fontsize=8)
    save_figure(figure, path)


def parse_plan(text: str) -> tuple[Planned, ...]:
    """``"GA:1M:5,PPO:5M:3"`` → the runs to make (method, budget with k/M, seeds)."""
    plan = []
    for item in filter(None, (part.strip() for part in text.split(","))):
        try:
            method, budget, seeds = item.split(":")
            scale = {"k": 1_000, "m": 1_000_000}.get(budget[-1:].lower(), 1)
            steps = int(float(budget[:-1] if scale > 1 else budget) * scale)
            planned = Planned(method.strip().upper(), steps, int(seeds))
        except ValueError:
            raise InputError(f"--plan {item!r}: expected METHOD:BUDGET:SEEDS, e.g. GA:1M:5")\
                from None
        if planned.method not in METHODS or not 1 <= planned.budget_steps <= 10**10 \
                or not 1 <= planned.seeds <= 100:
            raise InputError(f"--plan {item!r}: METHOD one of {', '.join(METHODS)}, BUDGET "
                             "1 to 10^10 steps, SEEDS 1 to 100")
        plan.append(planned)
    if not plan:
        raise InputError("--plan names no run")
    return tuple(plan)


def summary_text(out: Path) -> str:
    """The summary table as the command prints it."""
    table = _read(out / "comparison_summary.csv")
    if table.empty:
        return "no run finished"
    shown = table[["scenario", "method", "budget_steps", "seeds", "test_situations",
                   "test_fitness", "seeds_low", "seeds_high", "wall_s"]].copy()
    for column in ("test_fitness", "seeds_low", "seeds_high", "wall_s"):
        shown[column] = shown[column].map("{:.0f}".format)
    return shown.to_string(index=False)


def default_workers() -> int:
    return max(1, min(os.cpu_count() or 1, 8))
