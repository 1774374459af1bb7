"""Helpers the experiments share: where scenarios live, and reusable runs."""

from __future__ import annotations

from pathlib import Path

import pandas as pd

from enn_traffic.errors import InputError
from enn_traffic.runner import evolve
from enn_traffic.scenario import Scenario, load_scenario

SCENARIOS = Path(__file__).resolve().parents[2] / "scenarios"


def scenario(name: str) -> Scenario:
    """A shipped scenario by name (``scenarios/NAME.toml``)."""
    return load_scenario(SCENARIOS / f"{name}.toml")


def run_or_reuse(scenario: Scenario, out: Path, progress: bool, **options) -> pd.DataFrame:
    """Evolve into ``out``; a finished run there with the same settings is reused and an
    interrupted one resumed."""
    try:
        return evolve(scenario, out, resume=True, progress=progress, **options)
    except InputError:
        return evolve(scenario, out, force=True, progress=progress, **options)


def seed_runs(name: str, out: Path, seeds, ga: dict, progress: bool, label: str = "",
              **overrides) -> dict[int, pd.DataFrame]:
    """One run of scenario ``name`` per seed under ``out/runs/LABEL/seedN`` (LABEL defaults to
    the name); runs of equal settings share a folder, so they are done once."""
    base = scenario(name)
    runs = {}
    for seed in seeds:
        sc = base.with_overrides(seed=seed, ga=ga, **overrides)
        runs[seed] = run_or_reuse(sc, out / "runs" / (label or name) / f"seed{seed}", progress)
    return runs


def first_generation(table: pd.DataFrame, threshold: float) -> float:
    """The first generation whose best fitness reaches ``threshold`` (NaN if none)."""
    hits = table.loc[table["best_fitness"] >= threshold, "generation"]
    return float(hits.iloc[0]) if len(hits) else float("nan")
