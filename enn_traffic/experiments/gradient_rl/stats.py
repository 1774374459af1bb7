"""The comparison's tables: each method's test fitness over seeds, its difference from the
GA's with family-corrected intervals, and how the gap changes between the spin rules."""

from __future__ import annotations

import numpy as np
import pandas as pd

from enn_traffic.experiments.gradient_rl.protocol import METHODS, RUN_KEYS
from enn_traffic.report.stats import above_share, holm, permutation_p, t_interval, welch_contrast


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


# Scenarios that differ in their spin rule alone: the paper's first, the second
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
