"""The comparison's runs (``enn-traffic baseline``): the search, then every planned run not yet
in the folder, side by side in worker processes, each written as it ends, so that the same
command continues an interrupted comparison; then its tables and figure."""

from __future__ import annotations

import os
from collections.abc import Callable
from concurrent.futures import ProcessPoolExecutor, as_completed
from functools import partial
from pathlib import Path

import numpy as np
import pandas as pd

from enn_traffic.config import Scenario
from enn_traffic.core import interrupts as stopping
from enn_traffic.core.errors import InputError
from enn_traffic.core.io import write_atomic
from enn_traffic.core.progress import log, terminal
from enn_traffic.experiments import facts
from enn_traffic.experiments.gradient_rl.protocol import (
    PLAN,
    RUN_KEYS,
    SEARCH,
    SEARCH_BUDGET,
    TUNING_SEED,
    VALIDATION_SITUATIONS,
    Planned,
    check_protocol,
    check_scenarios,
)
from enn_traffic.experiments.gradient_rl.runs import RunResult, run_one
from enn_traffic.experiments.gradient_rl.stats import differences, rule_changes, summary
from enn_traffic.report.figures import comparison_figure
from enn_traffic.report.stats import bootstrap_interval


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


def write_summary(out: Path) -> pd.DataFrame:
    """``out/comparison_summary.csv``, ``comparison_differences.csv``,
    ``comparison_rules.csv`` and ``comparison.png`` from the runs' CSVs."""
    runs = _read(out / "comparison.csv")
    table = summary(runs, _read(out / "curves.csv"))
    write_atomic(out / "comparison_summary.csv", partial(table.to_csv, index=False))
    write_atomic(out / "comparison_differences.csv",
                 partial(differences(runs).to_csv, index=False))
    write_atomic(out / "comparison_rules.csv", partial(rule_changes(runs).to_csv, index=False))
    comparison_figure(_read(out / "curves.csv"), _read(out / "comparison.csv"),
                      out / "comparison.png")
    facts.write_all(out, "baseline")
    return table


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
