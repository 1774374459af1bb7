"""The comparison's protocol (docs/results.md, "The GA against gradient RL"), the same for every
method:

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

import json
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from enn_traffic.config import Scenario, scenario_digest
from enn_traffic.core import keys
from enn_traffic.core.errors import InputError
from enn_traffic.core.io import write_atomic

METHODS = ("GA", "PPO", "SAC")
RUN_KEYS = ["scenario", "method", "budget_steps", "seed"]  # a run's row in every CSV
# Keys of this comparison alone (the ledger, enn_traffic.core.keys): this round's, and the test
# keys its earlier rounds read; no start of its validation situations is a start of its test
# situations (DISTINCT_STARTS).
FIRST_ROUND_TEST_KEY = keys.COMPARISON_FIRST_ROUND_TEST.start
SECOND_ROUND_TEST_KEY = keys.COMPARISON_SECOND_ROUND_TEST.start
VALIDATION_KEY = keys.COMPARISON_VALIDATION.start
TEST_KEY = keys.COMPARISON_TEST.start
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


# The plan: ten independent seeds of every method at 1 M learner-steps, five of the GA and PPO
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


# The search: twelve settings of every method, exploration among the axes (the
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
# end within it. The flag records the protocol in protocol.json, so that a folder of runs
# made otherwise is refused.
WITHIN_BUDGET = True


def run_seed(seed: int, budget: int) -> np.random.SeedSequence:
    """A run's own random stream: from its seed and its budget, so that a run at 5 M steps is
    no continuation of the same seed's run at 1 M."""
    return np.random.SeedSequence([seed, budget])


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
            theirs = json.loads(path.read_text(encoding="utf-8"))
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
            known = dict(json.loads(path.read_text(encoding="utf-8")))
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
