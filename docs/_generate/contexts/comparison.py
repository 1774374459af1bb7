"""Context part: comparison (docs/_generate/README.md), docs/results.md's "The GA against
gradient RL" from the comparison's folder (``enn-traffic baseline``'s, ``results/baseline``):
its tables, its ``protocol.json`` and ``scenarios.json`` (the folder's, not today's), and its
facts (``facts/*.json``, :mod:`enn_traffic.experiments.gradient_rl.facts`). Here only rows and
columns are picked, grouped and summed, averaged or counted as a reader would. Its names are
this part's own: the parts of a document are merged, and a name two parts give is an error.
"""

from __future__ import annotations

import json
from pathlib import Path

import pandas as pd

from enn_traffic.experiments.facts import read as read_facts

GROUP = ["scenario", "method", "budget_steps"]


def records(table: pd.DataFrame) -> list[dict]:
    return table.to_dict("records")


def _spin_rule(table: pd.DataFrame) -> dict:
    """``spin_rule.csv`` as its table: a row per candidate variance (in the file's order), a
    cell per gain."""
    gains = sorted(table["gain"].unique())
    rows = [{"variance": variance, "cells": [group.set_index("gain").loc[gain].to_dict()
                                             for gain in gains]}
            for variance, group in table.groupby("spin_variance", sort=False)]
    return {"gains": gains, "rows": rows, "situations": table["situations"].iloc[0],
            "first_key": table["first_key"].iloc[0]}


def _search(tuning: pd.DataFrame, chosen: dict) -> dict:
    """``tuning.csv``: the settings searched per method, and per scenario and method the
    chosen setting's validation fitness, the median and the worst."""
    rows = []
    for (name, method), group in tuning.groupby(["scenario", "method"]):
        setting = chosen[name][method]
        fitness = group["validation_fitness"]
        rows.append({"scenario": name, "method": method, "setting": setting,
                     "best": group.set_index("setting").loc[setting, "validation_fitness"],
                     "median": fitness.median(), "worst": fitness.min(),
                     "settings": len(group)})
    counts = tuning.groupby("method")["setting"].nunique()
    return {"rows": rows, "counts": counts.to_dict(), "budget": tuning["budget_steps"].iloc[0],
            "seed": tuning["seed"].iloc[0]}


def differences_table(differences: pd.DataFrame, runs: pd.DataFrame) -> dict:
    """``comparison_differences.csv``: a row per scenario, method and budget with a cell per
    GA budget; and the comparisons at the same budget, each scenario's in the file's order,
    with the seeds' median test fitness of the method and of the GA."""
    median = runs.groupby(GROUP)["test_fitness"].median()
    rows = [{"scenario": name, "method": method, "budget_steps": budget,
             "cells": {row["ga_budget_steps"]: row for row in records(group)}}
            for (name, method, budget), group in differences.groupby(GROUP)]
    same = differences[differences["budget_steps"] == differences["ga_budget_steps"]]
    verdicts = [{"scenario": name, "rows": [
                    row | {"median": median[name, row["method"], row["budget_steps"]],
                           "ga_median": median[name, "GA", row["ga_budget_steps"]]}
                    for row in records(group)]}
                for name, group in same.groupby("scenario", sort=False)]
    return {"ga_budgets": sorted(differences["ga_budget_steps"].unique()), "rows": rows,
            "verdicts": verdicts}


def _travel(travel: pd.DataFrame) -> list[dict]:
    """``travel.csv`` per scenario, method and budget: its runs' counts summed, the medians
    of their medians, the least extent, the mean fitness under each rule."""
    rows = []
    for (name, method, budget), group in travel.groupby(GROUP):
        rows.append({"scenario": name, "method": method, "budget_steps": budget,
                     "runs": len(group), "long_lives": group["long_lives"].sum(),
                     "situations": group["situations"].sum(), "capped": group["capped"].sum(),
                     "circling": group["circling"].sum(), "turned": group["turned"].sum(),
                     "end_visits": group["median_end_visits"].median(),
                     "distance": group["median_distance"].median(),
                     "least_extent": group["least_tail_extent"].min(),
                     "fitness": group["fitness"].mean(),
                     "other_rule_fitness": group["other_rule_fitness"].mean(),
                     "other_rule_spins": group["other_rule_spins"].sum()})
    return rows


def _search_past(tuning: pd.DataFrame, scenario: str, track: dict) -> dict:
    """Per method, how many of its search runs in ``scenario`` scored on validation above the
    steps a life lasts that drives the corridor's length once (so turned round), of how
    many."""
    rows = tuning[tuning["scenario"] == scenario]
    steps = track["length"] / track["step_length"]
    return {method: {"above": int((group["validation_fitness"] > steps).sum()),
                     "of": len(group)} for method, group in rows.groupby("method")}


def context(root: Path) -> dict:
    folder = root / "results" / "baseline"
    facts = read_facts(folder)
    runs = pd.read_csv(folder / "comparison.csv")
    travel = pd.read_csv(folder / "travel.csv")
    tuning = pd.read_csv(folder / "tuning.csv")
    rules = {rule["rule"]: name for name, rule in facts["plan"]["scenarios"].items()
             if rule["rule"]}
    return {"comparison": {
        "protocol": json.loads((folder / "protocol.json").read_text(encoding="utf-8")),
        "scenarios": list(json.loads((folder / "scenarios.json").read_text(encoding="utf-8"))),
        "facts": facts,
        "spin_rule": _spin_rule(pd.read_csv(folder / "spin_rule.csv")),
        "rule_scenarios": rules,
        "search": _search(tuning, facts["search"]["chosen"]),
        "search_past_length": _search_past(tuning, rules["second"], facts["track"]),
        "differences": differences_table(pd.read_csv(folder / "comparison_differences.csv"), runs),
        "rules": records(pd.read_csv(folder / "comparison_rules.csv")),
        "travel_situations": travel["situations"].iloc[0],
        "travel": _travel(travel),
        "training_lives": records(pd.read_csv(folder / "training_lives.csv").sort_values(
            ["scenario", "method"]))}}
