"""The comparison's facts (docs/_generate/README.md): what docs/results.md's "The GA against
gradient RL" states that its folder's tables (``results/baseline``) do not hold, each computed
here from them, once, and written to ``facts/NAME.json`` beside them
(:mod:`enn_traffic.experiments.facts`, kind ``baseline``): the protocol in force beyond
``protocol.json`` (its plan, the search's size, the scenarios' spin rules and step caps, the
travel table's thresholds), the narrow track's length, width and starts, the spin rule chosen,
each search's choice, the test fitness over seeds, and the ablations' Welch intervals.

Each function takes the comparison's folder and returns a dict of JSON values (a missing
value is ``None``, never NaN: a facts file is compared with what its tables give).
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pandas as pd

from enn_traffic.experiments.gradient_rl import protocol as round_protocol
from enn_traffic.experiments.gradient_rl import stats


def _value(value: object) -> object:
    """A JSON value: numpy's scalars as Python's, NaN as ``None``."""
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, float) and math.isnan(value):
        return None
    return value


def _runs(folder: Path) -> pd.DataFrame:
    return pd.read_csv(folder / "comparison.csv")


def _shipped(folder: Path) -> dict:
    """The scenarios the folder's runs were made with (``scenarios.json``) that ship with the
    package unchanged (the same digest), by name; another scenario's name maps to ``None``:
    its settings are not known here."""
    from enn_traffic.config import scenario_digest
    from enn_traffic.config.shipped import SCENARIOS, shipped_scenario

    found = {}
    for name, digest in json.loads((folder / "scenarios.json").read_text()).items():
        shipped = (SCENARIOS / f"{name}.toml").is_file() and shipped_scenario(name)
        found[name] = shipped if shipped and scenario_digest(shipped) == digest else None
    return found


def plan(folder: Path) -> dict:
    """The protocol in force beyond ``protocol.json``: the runs planned per scenario, the
    search's settings per method, each scenario's spin rule (its ``spin_variance``, and
    ``paper`` or ``second`` where a pair of scenarios differs in it alone) and step cap, and
    the thresholds of ``travel.csv``. The package's constants, kept with the folder: a change
    to them shows as this file differing from what its folder gives. A scenario that does not
    ship with the package unchanged has no step cap here (``None``)."""
    from enn_traffic.experiments.gradient_rl import spin_rule

    runs = _runs(folder)
    tuning = pd.read_csv(folder / "tuning.csv")
    shipped = _shipped(folder)
    rules = dict(zip(runs["scenario"], runs["spin_variance"], strict=True))
    role = {name: "paper" if name == pair[0] else "second"
            for pair in stats.RULE_PAIRS for name in pair}
    scenarios = {}
    for name in sorted(set(rules) | set(tuning["scenario"])):
        episode = shipped[name].episode if shipped.get(name) else None
        variance = rules.get(name, episode and episode.spin_variance)
        scenarios[name] = {"spin_variance": _value(None if variance is None else float(variance)),
                           "rule": role.get(name),
                           "max_steps": episode and int(episode.max_steps)}
    return {
        "plan": [{"method": p.method, "budget_steps": p.budget_steps, "seeds": p.seeds}
                 for p in round_protocol.PLAN],
        "search_settings": {method: len(settings)
                            for method, settings in round_protocol.SEARCH.items()},
        "scenarios": scenarios,
        "travel": {"long": spin_rule.LONG, "tail": spin_rule.TAIL,
                   "circling": spin_rule.CIRCLING, "end_radius": spin_rule.END_RADIUS}}


def starts(folder: Path) -> dict:
    """The narrow track's starts under the folder's ``protocol.json``: how many of its test
    starts are distinct and how many also start a validation situation, how many starts the
    track has and how many validation and test take, the median distance from a test start to
    the nearest validation start facing the same way, and the training start's distance to
    the nearest test start (m)."""
    from enn_traffic.config.shipped import shipped_scenario
    from enn_traffic.envs.rangefinder import rangefinder_world
    from enn_traffic.experiments.gradient_rl import scoring

    protocol = json.loads((folder / "protocol.json").read_text())
    narrow = shipped_scenario("navigation_narrow")
    training = scoring.start_of(rangefinder_world(narrow).situations(0)[0])
    scored = scoring.scoring_scenario(narrow)
    world = rangefinder_world(scored)

    def starts_of(chosen: list[int], count: int) -> list[tuple]:
        return [scoring.start_of(situation) for key in chosen
                for situation in world.situations(key)][:count]

    validation_keys, test_keys = scoring.held_out_keys(scored, protocol)
    validation = set(starts_of(validation_keys, protocol["validation_situations"]))
    test = starts_of(test_keys, protocol["test_situations"])

    def nearest(start: tuple, among: set) -> float:  # facing the same way
        return min((np.hypot(start[0] - x, start[1] - y) for x, y, heading in among
                    if abs(np.angle(np.exp(1j * (heading - start[2])))) < 0.1), default=np.inf)

    return {"distinct": len(set(test)),
            "shared": sum(start in validation for start in test),
            "track": len(world.starts), "used": len(validation | set(test)),
            "validation_nearest": float(np.median([nearest(start, validation)
                                                   for start in test])),
            "training_nearest": float(min(np.hypot(x - training[0], y - training[1])
                                          for x, y, _ in test))}


def track(folder: Path) -> dict:
    """The narrow track the comparison drives (its shipped scenario and road network): the
    corridor's length between its dead ends (m, its edges' lengths summed: one road), its
    width (m, the narrowest edge's lanes together), how many dead ends it has, and how far
    the learner drives in a step (m, speed × dt)."""
    from enn_traffic.config.shipped import shipped_scenario
    from enn_traffic.experiments.gradient_rl.spin_rule import dead_ends
    from enn_traffic.roads.network import read_net

    narrow = shipped_scenario("navigation_narrow")
    net = read_net(Path(narrow.track.net))
    return {"length": float(sum(edge.getLength() for edge in net.getEdges())),
            "width": float(min(sum(lane.getWidth() for lane in edge.getLanes())
                               for edge in net.getEdges())),
            "dead_ends": len(dead_ends(narrow)),
            "step_length": float(narrow.vehicle.speed * narrow.vehicle.dt)}


def spin_rule(folder: Path) -> dict:
    """The second spin rule, chosen from ``spin_rule.csv``
    (:func:`~enn_traffic.experiments.gradient_rl.spin_rule.chosen_variance`)."""
    from enn_traffic.experiments.gradient_rl.spin_rule import chosen_variance

    return {"chosen_variance": chosen_variance(pd.read_csv(folder / "spin_rule.csv"))}


def search(folder: Path) -> dict:
    """Each scenario's and method's setting chosen by the search (``tuning.csv``,
    :func:`~enn_traffic.experiments.gradient_rl.campaign.chosen_setting`: a tie goes to the
    setting listed first)."""
    from enn_traffic.experiments.gradient_rl.campaign import chosen_setting

    tuning = pd.read_csv(folder / "tuning.csv")
    chosen: dict[str, dict[str, str]] = {}
    for name, method in sorted(set(zip(tuning["scenario"], tuning["method"], strict=True))):
        chosen.setdefault(name, {})[method] = chosen_setting(tuning, name, method)
    return {"chosen": chosen}


def fitness(folder: Path) -> dict:
    """Per scenario, method and budget, from the runs' rows (``comparison.csv``; a run's
    other rows are written before its comparison row): the seeds' mean test fitness with its
    90% t interval (:func:`~enn_traffic.experiments.gradient_rl.stats.summary`) cut to the
    fitness a run can have (0 to the scenario's step cap), the runs' least and greatest, the
    share of all their test situations at the cap (a scenario that does not ship with the
    package: no cap known, none), the seeds planned, and the summary's
    learner-steps, candidates, last chosen, validation − test and wall time."""
    keys = round_protocol.RUN_KEYS
    runs = _runs(folder)
    shipped = _shipped(folder)
    table = stats.summary(runs, pd.read_csv(folder / "curves.csv").merge(runs[keys], on=keys))
    situations = pd.read_csv(folder / "situations.csv").merge(runs[keys], on=keys)
    planned = {(p.method, p.budget_steps): p.seeds for p in round_protocol.PLAN}
    rows = []
    for row in table.itertuples():
        group = ["scenario", "method", "budget_steps"]
        values = (row.scenario, row.method, row.budget_steps)
        mine = runs[np.logical_and.reduce([runs[k] == v for k, v in zip(group, values,
                                                                         strict=True)])]
        lived = situations[np.logical_and.reduce(
            [situations[k] == v for k, v in zip(group, values, strict=True)])]["test_fitness"]
        cap = shipped[row.scenario].episode.max_steps if shipped.get(row.scenario) else None
        rows.append({key: _value(value) for key, value in {
            "scenario": row.scenario, "method": row.method, "budget_steps": row.budget_steps,
            "seeds": row.seeds, "planned_seeds": planned.get((row.method, row.budget_steps)),
            "test_fitness": row.test_fitness, "low": max(row.seeds_low, 0),
            "high": row.seeds_high if cap is None else min(row.seeds_high, cap),
            "least": mine["test_fitness"].min(), "greatest": mine["test_fitness"].max(),
            "at_cap": None if cap is None else (lived >= cap).mean(),
            "learner_steps": row.learner_steps, "candidates": row.candidates,
            "last_chosen": row.last_chosen, "validation_minus_test": row.validation_minus_test,
            "wall_s": row.wall_s}.items()})
    return {"rows": rows}


def _minus(mine: pd.Series, ga: pd.Series) -> dict:
    """The difference of two groups' means with its 90% Welch t interval (``None`` where the
    groups give no interval)."""
    from enn_traffic.report.stats import welch_contrast

    estimate, low, high = welch_contrast([mine, ga], [1, -1])
    return {"minus": _value(float(estimate)), "low": _value(float(low)),
            "high": _value(float(high))}


def ablations(folder: Path) -> dict:
    """The step cap and the start state as ablations (``travel.csv``): per scenario, method
    and budget, the mean over seeds of each column (fitness under each lower cap, under the
    scenario's, and from the training start), and for PPO and SAC its difference from the
    GA's at the same budget with a 90% Welch t interval over seeds (uncorrected)."""
    travel = pd.read_csv(folder / "travel.csv")
    columns = [c for c in travel.columns if c.startswith("fitness_cap_")]
    columns += ["fitness", "training_start_fitness"]
    rows = []
    for name, runs in travel.groupby("scenario"):
        ga = dict(tuple(runs[runs["method"] == "GA"].groupby("budget_steps")))
        for (method, budget), group in runs.groupby(["method", "budget_steps"]):
            theirs = ga.get(budget) if method != "GA" else None
            cells = {column: {"mean": _value(float(group[column].mean()))}
                     | ({} if theirs is None else _minus(group[column], theirs[column]))
                     for column in columns}
            rows.append({"scenario": name, "method": method, "budget_steps": int(budget),
                         "cells": cells})
    caps = [int(column.removeprefix("fitness_cap_")) for column in columns[:-2]]
    return {"caps": caps, "columns": columns, "rows": rows}


def stopping(folder: Path) -> dict:
    """The stopping rule as an ablation (``curves.csv``, the runs of ``comparison.csv``): per
    scenario, method and budget, the mean over seeds of each run's chosen candidate (its best
    on validation) and its last, and for PPO and SAC the last ones' difference from the GA's
    last at the same budget with a 90% Welch t interval over seeds (uncorrected)."""
    keys = round_protocol.RUN_KEYS
    curves = pd.read_csv(folder / "curves.csv").merge(_runs(folder)[keys])
    runs = curves.sort_values("learner_steps").groupby(keys).agg(
        chosen=("validation_fitness", "max"),
        last=("validation_fitness", "last")).reset_index()
    rows = []
    for name, scenario_runs in runs.groupby("scenario"):
        ga = {budget: group["last"] for budget, group in
              scenario_runs[scenario_runs["method"] == "GA"].groupby("budget_steps")}
        for (method, budget), group in scenario_runs.groupby(["method", "budget_steps"]):
            minus = _minus(group["last"], ga[budget]) if method != "GA" and budget in ga else {}
            rows.append({"scenario": name, "method": method, "budget_steps": int(budget),
                         "chosen": _value(float(group["chosen"].mean())),
                         "last": _value(float(group["last"].mean()))} | minus)
    return {"rows": rows}
