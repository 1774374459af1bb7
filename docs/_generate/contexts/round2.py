"""Context part: round2 (docs/_generate/README.md), docs/results.md's "The second round" from
that round's folder (``results/baseline_round2``, finished: its tables never change): its
tables, its ``protocol.json``, and its facts (``facts/*.json``, the ``round2_`` functions of
:mod:`enn_traffic.experiments.gradient_rl.facts`: the narrow track's starts, the settings beyond
``protocol.json``, the saved controllers' networks, the intervals' level). Here only rows and
columns are picked, grouped, counted, averaged or divided as a reader would; the helpers the
current comparison's part has for the same tables are its (:mod:`contexts.comparison`). Its
one name, ``round2``, is this part's own.
"""

from __future__ import annotations

import json
import re
from pathlib import Path

import pandas as pd

from contexts.comparison import GROUP, differences_table, records
from enn_traffic.experiments.facts import read as read_facts


def _search(tuning: pd.DataFrame, runs: pd.DataFrame) -> dict:
    """``tuning.csv`` row by row (grouped per scenario and method in the file's order), each
    marked chosen where the runs of its scenario and method (``comparison.csv``) took its
    setting; the settings searched per method, the seeds a setting had, the search's seed and
    budget."""
    chosen = set(zip(runs["scenario"], runs["method"], runs["setting"], strict=True))
    rows = [row | {"chosen": (row["scenario"], row["method"], row["setting"]) in chosen}
            for _, group in tuning.groupby(["scenario", "method"], sort=False)
            for row in records(group)]
    seeds = tuning.groupby(["scenario", "method", "setting"])["seed"].nunique()
    return {"rows": rows, "counts": tuning.groupby("method")["setting"].nunique().to_dict(),
            "seeds_per_setting": int(seeds.max()), "seed": int(tuning["seed"].iloc[0]),
            "budget": int(tuning["budget_steps"].iloc[0])}


def _summary(summary: pd.DataFrame, runs: pd.DataFrame) -> list[dict]:
    """``comparison_summary.csv`` in the file's order, each row with its runs' least and
    greatest test fitness (``comparison.csv``)."""
    spread = runs.groupby(GROUP)["test_fitness"].agg(["min", "max"])
    return [row | {"least": spread.loc[tuple(row[key] for key in GROUP), "min"],
                   "greatest": spread.loc[tuple(row[key] for key in GROUP), "max"]}
            for row in records(summary)]


def _training_lives(lives: pd.DataFrame) -> dict:
    """``training_lives.csv`` per scenario and method, with the thresholds its
    ``lives_over_N`` columns count past (each row's counts in their order), the seed of its
    runs and how many runs a method has per scenario."""
    over = {int(match[1]): column for column in lives.columns
            if (match := re.fullmatch(r"lives_over_(\d+)", column))}
    thresholds = sorted(over)
    rows = [row | {"over": [row[over[threshold]] for threshold in thresholds]}
            for row in records(lives.sort_values(["scenario", "method"]))]
    return {"rows": rows, "thresholds": thresholds, "seed": int(lives["seed"].iloc[0]),
            "runs": int(lives.groupby(["scenario", "method"]).size().max())}


def _zero_shares(situations: pd.DataFrame) -> dict:
    """Per scenario and method, the share of its runs' test situations (``situations.csv``)
    that score 0."""
    shares = (situations["test_fitness"] == 0).groupby(
        [situations["scenario"], situations["method"]]).mean()
    found: dict[str, dict[str, float]] = {}
    for (name, method), share in shares.items():
        found.setdefault(name, {})[method] = share
    return found


def context(root: Path) -> dict:
    folder = root / "results" / "baseline_round2"
    protocol = json.loads((folder / "protocol.json").read_text(encoding="utf-8"))
    facts = read_facts(folder)
    runs = pd.read_csv(folder / "comparison.csv")
    summary = pd.read_csv(folder / "comparison_summary.csv")
    steps = {scenario["dt"] for scenario in facts["settings"]["scenarios"].values()}
    if len(steps) != 1:
        raise ValueError(f"the second round's scenarios step {sorted(steps)} s apart")
    seeds: dict[str, dict[int, int]] = {}
    for (method, budget), count in summary.groupby(["method", "budget_steps"])["seeds"].max(
            ).items():
        seeds.setdefault(method, {})[budget] = count
    return {"round2": {
        "protocol": protocol,
        "facts": facts,
        "scenarios": list(pd.unique(runs["scenario"])),
        "budgets": {method: sorted(group.unique())
                    for method, group in runs.groupby("method")["budget_steps"]},
        "all_budgets": sorted(runs["budget_steps"].unique()),
        "seeds": seeds,
        "most_seeds": int(summary["seeds"].max()),
        "step_s": steps.pop(),
        "search": _search(pd.read_csv(folder / "tuning.csv"), runs),
        "summary": _summary(summary, runs),
        "differences": differences_table(pd.read_csv(folder / "comparison_differences.csv"), runs),
        "training_lives": _training_lives(pd.read_csv(folder / "training_lives.csv")),
        "zero_shares": _zero_shares(pd.read_csv(folder / "situations.csv"))}}
