"""Context part: crowds (docs/_generate/README.md), docs/results.md's "All vehicles at once"
(Tables 3–4 in the arena, their ablation, the authors' last rules), "Among SUMO traffic" and
"Cologne under four SUMO driver models", and the README's rows of Tables 3–4 and the
ablation: the tables ``reproduce`` wrote into ``results/paper`` (and its ``sumo/`` and
``city/``), their facts (``facts/tables34.json``, ``table4_ablation.json``,
``sumo_tables34.json``, ``city_tables34.json``), ``summary.json``'s commits and wall times,
and the settings the package declares (the families, the crowds' learning, the key ledger,
the paper's numbers). Here rows and columns are only picked, counted and averaged as a reader
would. Its one name is ``crowds``."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd

from enn_traffic.config.shipped import shipped_scenario
from enn_traffic.core import keys
from enn_traffic.experiments import ablation, ablation_sumo, authors_rules, departures
from enn_traffic.experiments.crowds.arena import LEARNING, SECONDS
from enn_traffic.experiments.crowds.stats import ARMS
from enn_traffic.experiments.crowds.sumo import SITUATION_KEY as SUMO_SITUATION_KEY
from enn_traffic.experiments.crowds.sumo import SUMO_LEARNING
from enn_traffic.experiments.facts import read as read_facts
from enn_traffic.experiments.families import ARENA, CITY, SUMO, Family
from enn_traffic.report.paper import (
    PAPER_INITIAL,
    PAPER_REDUCTION,
    PAPER_TABLE1,
    PAPER_TABLE2,
    PAPER_TABLE3,
    PAPER_TABLE4,
)

BILLION = 10**9


def _native(value):
    """A table's cell as a Python value (numpy's scalars as Python's)."""
    return value.item() if isinstance(value, np.generic) else value


def _records(table: pd.DataFrame) -> list[dict]:
    return [{k: _native(v) for k, v in row.items()} for row in table.to_dict("records")]


def _apart(table: pd.DataFrame, name: str) -> dict:
    """How many rows have ``name``'s interval below 0 and how many above."""
    return {"below": int((table[f"{name}_high"] < 0).sum()),
            "above": int((table[f"{name}_low"] > 0).sum())}


def _learning(settings) -> dict:
    return {"learning_s": settings.learning_s, "window_s": settings.window_s,
            "windows": settings.windows, "life_cap_steps": settings.life_cap_steps,
            "population_size": settings.population_size, "elite_count": settings.elite_count}


def _learners(learners: pd.DataFrame, curve: dict) -> list[dict]:
    """Per strategy: the learners' generations bred, lives and chromosomes tried
    (``table4_learners.csv``), and each arm's learning curve from its first to its last tenth
    (the facts' ``curve``)."""
    ends = {row["strategy"]: row for row in curve["strategies"]}
    return [{"strategy": int(strategy), "bred_median": float(group["generations_bred"].median()),
             "bred_min": int(group["generations_bred"].min()),
             "bred_max": int(group["generations_bred"].max()),
             "lives": float(group["lives"].median()),
             "tried": float(group["chromosomes_tried"].median()), "curve": ends[strategy]}
            for strategy, group in learners.groupby("strategy")]


def _during(curve: pd.DataFrame) -> dict:
    """The learners' mean rate over the whole learning curve and the winner's beside it."""
    return {"learning": float(curve["collisions_per_vehicle_s"].mean()),
            "winner": float(curve["winner_driving_on"].mean())}


def _paper() -> dict:
    """The paper's numbers the sections set ours beside."""
    table1 = np.array(PAPER_TABLE1, dtype=float)
    off = ~np.eye(len(table1), dtype=bool)
    top = sum(bool(table1[i, i] > np.delete(table1[i], i).max()) for i in range(len(table1)))
    averages = [sum(row) / len(row) for row in PAPER_TABLE2]
    return {"table3": PAPER_REDUCTION["table3"], "table4": PAPER_REDUCTION["table4"],
            "initial_mean": round(float(np.mean(PAPER_INITIAL)), 2),
            "table4_below_table3": sum(a4 < a3 for (_, a3), (_, a4) in zip(
                PAPER_TABLE3, PAPER_TABLE4, strict=True)),
            "strategies": len(PAPER_TABLE3),
            "table1_ratio": float(np.diag(table1).mean() / table1[off].mean()),
            "table1_rows_on_top": top, "table1_rows": len(table1),
            "table2_share": averages[-1] / averages[0]}


def _regime(regime: pd.DataFrame) -> dict:
    """``regime.csv``: its rows, the paper's range, the configurations inside it per second,
    and the authors' set-up's lives lost in each time base, each inside the range or not."""
    low, high = float(regime["paper_low"].iloc[0]), float(regime["paper_high"].iloc[0])
    authors = regime.iloc[-1]
    inside = regime[(regime["lives_lost_per_s"] >= low) & (regime["lives_lost_per_s"] <= high)]
    bases = [{"name": name, "rate": float(authors[column]),
              "collisions": float(authors["collisions_per_s"] * authors[column]
                                  / authors["lives_lost_per_s"])}
             for name, column in (("second", "lives_lost_per_s"),
                                  ("step (0.1 s)", "lives_lost_per_step"),
                                  ("100 steps", "lives_lost_per_100_steps"))]
    return {"rows": _records(regime), "low": low, "high": high,
            "authors": float(authors["lives_lost_per_s"]),
            "inside": list(inside["configuration"]),
            "bases": bases, "bases_inside": [b["name"] for b in bases if low <= b["rate"] <= high],
            "collisions_inside": [b["name"] for b in bases if low <= b["collisions"] <= high]}


def _arena(paper: Path) -> dict:
    situations = pd.read_csv(paper / "simultaneous_situations.csv")
    means = pd.read_csv(paper / "simultaneous.csv")
    table3 = pd.read_csv(paper / "table3.csv")
    table4 = pd.read_csv(paper / "table4.csv")
    learners = pd.read_csv(paper / "table4_learners.csv")
    validation = pd.read_csv(paper / "table4_validation_learners.csv")
    curve = pd.read_csv(paper / "table4_learning.csv")
    facts = read_facts(paper, "tables34")
    fall = means["initial"] - means["initial_after"]
    drop = means[fall == fall.max()].iloc[0]
    kept = facts["kept"]
    contrasts = ["initial_after", "winner_after", "reranked"]
    paper_way = "paper_winner_minus_winner" in table3
    ga = shipped_scenario(ARENA.name(1)).ga
    regime = pd.read_csv(paper / "regime.csv")
    initial = regime[regime["configuration"] == "initial drivers"]["collisions_per_s"]
    return {
        "situations": int(situations.groupby("strategy")["situation"].nunique().iloc[0]),
        "key_billions": keys.CROWD_TEST.start // BILLION,
        "seconds": SECONDS, "spans": round(LEARNING.learning_s / SECONDS),
        "learning_s": LEARNING.learning_s, "life_cap_steps": LEARNING.life_cap_steps,
        "validation": {"situations": int(validation["situation"].nunique()),
                       "bred_min": int(validation["generations_bred"].min()),
                       "bred_max": int(validation["generations_bred"].max())},
        "means": _records(means), "table4": _records(table4),
        "contrasts": [{"name": name, "label": ARMS[name]} for name in contrasts],
        "apart": {name: _apart(table4, f"population_minus_{name}") for name in contrasts},
        "strategies": len(table4),
        "drop": {"strategy": float(drop["strategy"]), "initial": float(drop["initial"]),
                 "initial_after": float(drop["initial_after"])},
        "reductions": facts["reductions"],
        "baseline": float(means["initial"].mean()),
        "baseline_after": float(means["initial_after"].mean()),
        "below_paper_table3": [r["strategy"] for r in facts["table4_vs_paper_table3"]
                               if r["high"] < 0],
        "above_paper_table3": [r["strategy"] for r in facts["table4_vs_paper_table3"]
                               if r["low"] > 0],
        "below_table3": [r["strategy"] for r in facts["table4_vs_table3"] if r["high"] < 0],
        "above_table3": [r["strategy"] for r in facts["table4_vs_table3"] if r["low"] > 0],
        "paper_way": {"rows": _records(table3), "strategies": len(table3),
                      **_apart(table3, "paper_winner_minus_winner"),
                      "cut": float((1 - table3["paper_winner_collisions_per_s"]
                                    / table3["initial_collisions_per_s"]).mean()),
                      "ours": float((1 - table3["after_collisions_per_s"]
                                     / table3["initial_collisions_per_s"]).mean())}
        if paper_way else None,
        "kept": kept,
        "kept_share": sum(k["kept"] for k in kept) / sum(k["vehicles"] for k in kept),
        "capped": float(1 - learners["lives"].sum() / learners["chromosomes_tried"].sum()),
        "learners": _learners(learners, facts["curve"]),
        "generations_bred": float(learners["generations_bred"].median()),
        "tenth": max(1, round(LEARNING.learning_s / SECONDS) // 10),
        "during": _during(curve), "curve": facts["curve"]["all"], "trend": facts["trend"],
        "children": 1 - ga.elite_count / ga.population_size,
        "regime": _regime(regime),
        "initial_regime": {"low": float(initial.min()), "high": float(initial.max())},
    }


def _curve_ends(ends: list[dict]) -> list[dict]:
    """Each arm's learning curve over its last tenth, the range over the strategies."""
    table = pd.DataFrame(ends).groupby(["start_population", "stopping"], sort=False)
    return [{"start_population": start, "stopping": stopping, "authors": start == "authors",
             "low": float(rows["last_tenth"].min()), "high": float(rows["last_tenth"].max())}
            for (start, stopping), rows in table]


def _ablation(paper: Path) -> dict:
    table = pd.read_csv(paper / "table4_ablation.csv")
    factors = pd.read_csv(paper / "table4_ablation_factors.csv")
    situations = pd.read_csv(paper / "table4_ablation_situations.csv")
    facts = read_facts(paper, "table4_ablation")
    authors = situations[situations["start_population"] == "authors"].drop_duplicates("situation")
    winners = table.drop_duplicates("strategy")
    arms = []
    against = {(a["start_population"], a["stopping"]): a for a in facts["against_initial"]}
    for (start, stopping), arm in table.groupby(["start_population", "stopping"], sort=False):
        shared = (start, stopping) in ablation.SHARED
        once = arm.head(1)  # a shared arm against its own spans: one measurement
        arms.append({"start_population": start, "stopping": stopping,
                     "authors": start == "authors", "shared": shared,
                     "reduction": float(arm["reduction_vs_first_span"].mean()),
                     "against_initial": against[start, stopping],
                     "finished": float(arm["finished_share"].mean()),
                     "apart": {c: _apart(once if shared and c in ablation.OWN else arm,
                                         f"after_minus_{c}") for c in ablation.CONTRASTS},
                     "counted": {c: 1 if shared and c in ablation.OWN else len(arm)
                                 for c in ablation.CONTRASTS}})
    finished = {(arm["start_population"], arm["stopping"]): arm["finished"] for arm in arms}
    idle = [arm | {"finished": finished[arm["start_population"], arm["stopping"]]}
            for arm in facts["idle_arms"]]
    for arm in arms:
        arm["idle"] = any(arm["start_population"] == i["start_population"]
                          and arm["stopping"] == i["stopping"] for i in idle)
    outcome = "after_minus_first_span"
    count = int(table["situations"].iloc[0])
    sumo = pd.read_csv(paper / SUMO.folder / "table4_ablation.csv")
    first = pd.read_csv(paper / "table4_ablation_first_reading.csv")
    first_factors = pd.read_csv(paper / "table4_ablation_first_reading_factors.csv")
    frozen = facts["learners_vs_frozen"]
    first_reductions = first.groupby(["start_population", "stopping"], sort=False)[
        "reduction_vs_first_span"].mean()
    return {
        "population_size": shipped_scenario(ARENA.name(1)).ga.population_size,
        "cap": ablation.STOPPINGS["cap"]["life_cap_steps"],
        "finish_steps": ablation.FINISH_STEPS, "seconds": ablation.ABLATION.seconds,
        "authors_generations": ablation.AUTHORS_GENERATIONS,
        "authors_seconds": ablation.ABLATION.authors_seconds,
        "authors_learning": {"low": float(authors["learning_s"].min()),
                             "high": float(authors["learning_s"].max())},
        "situations": count, "key_billions": keys.ABLATION_CROWD_TEST.start // BILLION,
        "key_offset": ablation.ABLATION_KEY - keys.ABLATION_CROWD_TEST.start,
        "level": ablation.LEVEL, "intervals": len(table) * len(ablation.CONTRASTS),
        "rows": _records(table), "contrasts": ablation.CONTRASTS,
        "winners": _records(winners[["strategy", "winner_after", "winner_first"]]),
        "arms": arms, "strategies": int(table["strategy"].nunique()),
        "factors": _records(factors), "outcomes": ablation.FACTOR_OUTCOMES,
        "factors_by_outcome": [row for name in ablation.FACTOR_OUTCOMES
                               for row in _records(factors[factors["outcome"] == name])],
        "start": _records(factors[(factors["factor"] == "start_population")
                                  & (factors["outcome"] == outcome)])[0],
        "stop": _records(factors[(factors["factor"] == "stopping")
                                 & (factors["outcome"] == outcome)])[0],
        "t_intervals": facts["t_intervals"],
        "counted": {c: sum(arm["counted"][c] for arm in arms) for c in ablation.CONTRASTS},
        "learners_vs_frozen": frozen,
        "learners_above_frozen": [r["strategy"] for r in frozen if r["low"] > 0],
        "learners_below_frozen": [r["strategy"] for r in frozen if r["high"] < 0],
        "curve_ends": _curve_ends(facts["curve_ends"]),
        "first_stopping": _records(first_factors[(first_factors["factor"] == "stopping") & (
            first_factors["contrast"] == "after_minus_initial_after")])[0],
        "stop_after": _records(factors[(factors["factor"] == "stopping")
                                       & (factors["outcome"] == "after")])[0],
        "start_after": _records(factors[(factors["factor"] == "start_population")
                                        & (factors["outcome"] == "after")])[0],
        "idle": idle, "idle_finish": any(arm["stopping"] != "cap" for arm in idle),
        "sumo": {"strategy": ablation_sumo.SUMO_STRATEGY, "rows": _records(sumo),
                 "situations": int(sumo["situations"].iloc[0]),
                 "key_offset": ablation_sumo.SUMO_KEY - keys.ABLATION_CROWD_TEST.start,
                 "folder": SUMO.folder} | _learning(SUMO_LEARNING),
        "first_reading": {"rows": len(first), "situations": int(first["situations"].iloc[0]),
                          "above_winner": int((first["after_minus_winner_after_low"] > 0).sum()),
                          "reductions": [{"start_population": start, "stopping": stop,
                                          "reduction": float(r)}
                                         for (start, stop), r in first_reductions.items()]},
    }


def _departures(paper: Path) -> dict:
    table = pd.read_csv(paper / "departures.csv")
    situations = pd.read_csv(paper / "departures_situations.csv")
    ga = shipped_scenario(ARENA.name(1)).ga
    groups = [{"name": name, "moved": _records(rows[(rows["difference_low"] > 0)
                                                   | (rows["difference_high"] < 0)])}
              for name, rows in table.groupby("departure", sort=False)]
    means = situations.groupby("variant", sort=False)[["first_span", "after"]].mean()
    after = table[table["measure"] == "after"]
    authors = pd.read_csv(paper / "table4_ablation.csv").query("start_population == 'authors'")
    count = int(table["situations"].iloc[0])
    return {
        "bred_from": ga.population_size - ga.elite_count,
        "authors_generations": ablation.AUTHORS_GENERATIONS,
        "learning": {"low": float(situations["learning_s"].min()),
                     "high": float(situations["learning_s"].max())},
        "situations": count, "key_billions": keys.ABLATION_CROWD_TEST.start // BILLION,
        "key_offset": departures.DEPARTURE_KEY - keys.ABLATION_CROWD_TEST.start,
        "level": ablation.LEVEL, "rows": _records(table), "measures": departures.MEASURES,
        "groups": groups,
        "zero": _records(table[(table["difference_low"] == 0) & (table["difference_high"] == 0)]),
        "widest": _records(after.loc[[after["difference_high"].idxmax()]])[0],
        "falls": [{"name": name, "fall": float(1 - row["after"] / row["first_span"])}
                  for name, row in means.iterrows()],
        "ablation_authors": float(authors["reduction_vs_first_span"].mean()),
    }


def _authors_rules(paper: Path) -> dict:
    table = pd.read_csv(paper / "authors_rules.csv")
    situations = pd.read_csv(paper / "authors_rules_situations.csv")
    none = authors_rules.NONE
    same = situations.pivot(index="situation", columns="variant", values="first_span")
    moved = []
    for row in _records(table[table["variant"] != none]):
        alike = bool((same[row["variant"]] == same[none]).all())  # the same by construction
        moved.append({"variant": row["variant"], "measures": [
            {"measure": m, "up": row[f"{m}_vs_none_low"] > 0} for m in authors_rules.MEASURES
            if (row[f"{m}_vs_none_low"] > 0 or row[f"{m}_vs_none_high"] < 0)
            and not (alike and m == "first_span")], "alike": alike})
    finishing = situations[[authors_rules.VARIANTS[v].until_finished
                            for v in situations["variant"]]]
    ablation_table = pd.read_csv(paper / "table4_ablation.csv")
    random = ablation_table[ablation_table["start_population"] == "random"]
    authors = float(ablation_table.query("start_population == 'authors'")
                    ["reduction_vs_first_span"].mean())
    return {
        "rows": _records(table), "measures": authors_rules.MEASURES, "moved": moved,
        "reaching": [row["variant"] for row in _records(table)
                     if row["fall_low"] <= authors <= row["fall_high"]],
        "alone": list(authors_rules.VARIANTS)[1:-1],  # each rule alone
        "situations": int(table["situations"].iloc[0]), "level": ablation.LEVEL,
        "intervals": int(table.filter(like="_low").notna().to_numpy().sum()),
        "key_billions": keys.ABLATION_CROWD_TEST.start // BILLION,
        "key_offset": authors_rules.RULES_KEY - keys.ABLATION_CROWD_TEST.start,
        "seconds": authors_rules.STEPS.seconds,
        "authors_seconds": authors_rules.STEPS.authors_seconds,
        "learning": {"low": float(finishing["learning_s"].min()),
                     "high": float(finishing["learning_s"].max())},
        "random_arms": {"low": float(random["reduction_vs_first_span"].min()),
                        "high": float(random["reduction_vs_first_span"].max())},
        "ablation_authors": authors,
    }


def _closed_loop(folder: Path, family: Family) -> dict:
    """``closed_loop.csv``: each strategy's mean lifetimes replayed and in closed loop, the
    situations that give the same lifetime both ways, the widest gap."""
    table = pd.read_csv(folder / "closed_loop.csv")
    means = table.groupby("strategy")[["replay_steps", "closed_loop_steps"]].mean()
    gap = (table["closed_loop_steps"] - table["replay_steps"]).abs().idxmax()
    return {"means": [{"strategy": int(s), "name": family.name(int(s)),
                       "replay": float(r.replay_steps), "closed_loop": float(r.closed_loop_steps)}
                      for s, r in means.iterrows()],
            "same": int((table["replay_steps"] == table["closed_loop_steps"]).sum()),
            "situations": len(table),
            "per_strategy": int(table.groupby("strategy").size().iloc[0]),
            "widest": _records(table.loc[[gap]])[0]}


def _matrix(table: pd.DataFrame) -> dict:
    """Table 1 as a reader reads it: each cell by row and column (from 1), the diagonal's mean
    and the rest's, the rows whose diagonal tops them, and per row the cells above its
    diagonal; per column its mean, its best row and the rows other than its own."""
    matrix = table.set_index("training_strategy").to_numpy()
    size = len(matrix)
    off = ~np.eye(size, dtype=bool)
    cells = {i + 1: {j + 1: float(matrix[i, j]) for j in range(size)} for i in range(size)}
    return {
        "cells": cells, "diagonal": float(np.diag(matrix).mean()),
        "rest": float(matrix[off].mean()), "rows": size,
        "on_top": [i + 1 for i in range(size) if matrix[i, i] > np.delete(matrix[i], i).max()],
        "above_own": {i + 1: [j + 1 for j in range(size) if j != i and matrix[i, j] > matrix[i, i]]
                      for i in range(size)},
        "column_means": {j + 1: float(matrix[:, j].mean()) for j in range(size)},
        "column_best": {j + 1: int(np.argmax(matrix[:, j])) + 1 for j in range(size)},
        "own_best": [j + 1 for j in range(size) if matrix[j, j] >= matrix[:, j].max()],
        "column_others": {j + 1: {"low": float(np.delete(matrix[:, j], j).min()),
                                  "high": float(np.delete(matrix[:, j], j).max())}
                          for j in range(size)},
        "column": {j + 1: {"low": float(matrix[:, j].min()), "high": float(matrix[:, j].max())}
                   for j in range(size)}}


def _conflicts(situations: pd.DataFrame) -> dict:
    """How often the 2-D conflicts per learner-hour exceed SSM's, strategy by arm (the cells
    of the results' conflict table: means over the situations)."""
    arms = ["initial", "winner", "initial_after", "winner_after", "population"]
    means = situations.groupby("strategy")[
        [f"{arm}_{m}" for arm in arms for m in ("conflicts", "conflicts_2d")]].mean()
    above = sum(int((means[f"{arm}_conflicts_2d"] > means[f"{arm}_conflicts"]).sum())
                for arm in arms)
    rates = situations[["initial", "winner"]].mean() * 3600.0  # collisions per learner-hour
    return {"above": above, "cells": len(means) * len(arms),
            "winner_more": int((means["winner_conflicts_2d"]
                                > means["initial_conflicts_2d"]).sum()),
            "per_collision": {arm: float(situations[f"{arm}_conflicts_2d"].mean() / rates[arm])
                              for arm in ("initial", "winner")}}


def _family(paper: Path, family: Family, summary: dict) -> dict:
    folder = paper / family.folder
    table3 = pd.read_csv(folder / "table3.csv")
    table4 = pd.read_csv(folder / "table4.csv")
    learners = pd.read_csv(folder / "table4_learners.csv")
    validation = pd.read_csv(folder / "table4_validation_learners.csv")
    curve = pd.read_csv(folder / "table4_learning.csv")
    situations = pd.read_csv(folder / "crowd_situations.csv")
    facts = read_facts(paper, f"{family.folder}_tables34")
    fig11 = pd.read_csv(folder / "fig11.csv")
    medians = fig11.groupby("strategy")[["rise", "mean_rise", "held_out_rise", "first_held_out",
                                         "last5_mean_held_out"]].median()
    table2 = pd.read_csv(folder / "table2.csv")
    names = [c for c in table2.columns if c.startswith("strategy_")]
    scenario = family.scenario(1)
    run = summary[family.folder]
    return {
        "folder": family.folder, "learners_per_sumo": scenario.traffic.learners,
        "situations": int(situations.groupby("strategy")["situation"].nunique().iloc[0]),
        "key_billions": keys.CROWD_TEST.start // BILLION,
        "key_offset": SUMO_SITUATION_KEY - keys.CROWD_TEST.start,
        "learning": _learning(SUMO_LEARNING),
        "validation": {"situations": int(validation["situation"].nunique()),
                       "bred_min": int(validation["generations_bred"].min()),
                       "bred_max": int(validation["generations_bred"].max())},
        "rows": [{"first": first, "after": after} for first, after in zip(
            _records(table3), _records(table4), strict=True)],
        "winner_below": _apart(table3, "winner_minus_initial")["below"],
        "conflicts": _conflicts(situations),
        "warmups": scenario.traffic.warmup_states,
        "strategies": len(table4),
        "apart": {name: _apart(table4, f"population_minus_{name}")
                  for name in ("initial_after", "winner_after")},
        "learners": _learners(learners, facts["curve"]),
        "initial_life": float(1 / situations["initial"].mean()),
        "lanes": facts["lanes"], "during": _during(curve), "trend": facts["trend"],
        "closed_loop": _closed_loop(folder, family),
        "settings": {"population": scenario.ga.population_size,
                     "generations": scenario.ga.generations, "seeds": len(family.seeds),
                     "episodes": scenario.traffic.episodes, "cap": scenario.episode.max_steps,
                     "hidden": scenario.network.hidden[0],
                     "test_situations": family.test_situations,
                     "recheck_situations": family.recheck_situations,
                     "table_situations": family.table_situations,
                     "incremental_seeds": len(family.incremental_seeds),
                     "threshold": round(family.threshold),
                     "accepted_fitness": round(family.accepted_fitness),
                     "max_generations": family.incremental_max_generations},
        "run": {"commit": run["commit"][:7], "code": run["code"], "seconds": run["seconds"]},
        "fig11": {"rise": {int(s): float(v) for s, v in medians["rise"].items()},
                  "held_out_rise": {int(s): float(v)
                                    for s, v in medians["held_out_rise"].items()},
                  "first_held_out": {int(s): float(v)
                                     for s, v in medians["first_held_out"].items()},
                  "last_held_out": {int(s): float(v)
                                    for s, v in medians["last5_mean_held_out"].items()},
                  "mean_rise_low": float(medians["mean_rise"].min()),
                  "mean_rise_high": float(medians["mean_rise"].max()),
                  "all_capped": bool((fig11["max_best"] >= scenario.episode.max_steps).all()),
                  "strategy1_first_held_out": {
                      "low": float(fig11[fig11["strategy"] == 1]["first_held_out"].min()),
                      "high": float(fig11[fig11["strategy"] == 1]["first_held_out"].max())}},
        "table1": _matrix(pd.read_csv(folder / "table1.csv")),
        "table2": {"first": float(table2["average"].iloc[0]),
                   "last": float(table2["average"].iloc[-1]),
                   "unaccepted": [int(i) for i in
                                  table2[~table2["reached_threshold"]]["iteration"]],
                   "iterations": len(table2),
                   "last_row": {int(n.removeprefix("strategy_")): float(table2[n].iloc[-1])
                                for n in names},
                   "worst": int(min(names, key=lambda n: table2[n].iloc[-1])
                                .removeprefix("strategy_"))},
    }


def context(root: Path) -> dict:
    paper = root / "results" / "paper"
    summary = json.loads((paper / "summary.json").read_text(encoding="utf-8"))
    return {"crowds": {"paper": _paper(), "arena": _arena(paper), "ablation": _ablation(paper),
                       "departures": _departures(paper),
                       "authors_rules": _authors_rules(paper),
                       "sumo": _family(paper, SUMO, summary),
                       "city": _family(paper, CITY, summary)}}
