"""The comparison's facts (docs/_generate/README.md): what docs/results.md's "The GA against
gradient RL" states that its folder's tables (``results/baseline``) do not hold, each computed
here from them, once, and written to ``facts/NAME.json`` beside them
(:mod:`enn_traffic.experiments.facts`, kind ``baseline``): the protocol in force beyond
``protocol.json`` (its plan, the search's size, the scenarios' spin rules and step caps, the
travel table's thresholds), the narrow track's length, width and starts, the spin rule chosen,
each search's choice, the test fitness over seeds, and the ablations' Welch intervals. And
those of the comparison's second round (kind ``baseline_round2``, ``results/baseline_round2``,
the ``round2_`` functions): its narrow track's starts, the settings beyond its
``protocol.json``, its controllers' networks and its intervals' level.

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
    for name, digest in json.loads((folder / "scenarios.json").read_text(encoding="utf-8")).items():
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


def _narrow_starts(protocol: dict) -> tuple[tuple, int, list[tuple], list[tuple]]:
    """The narrow track's starts under a round's ``protocol`` (its ``protocol.json``): the
    training start, how many starts the track has to score from, and the starts of the
    validation and of the test situations, in order
    (:func:`~enn_traffic.experiments.gradient_rl.scoring.held_out_keys`)."""
    from enn_traffic.config.shipped import shipped_scenario
    from enn_traffic.envs.rangefinder import rangefinder_world
    from enn_traffic.experiments.gradient_rl import scoring

    narrow = shipped_scenario("navigation_narrow")
    training = scoring.start_of(rangefinder_world(narrow).situations(0)[0])
    scored = scoring.scoring_scenario(narrow)
    world = rangefinder_world(scored)

    def starts_of(chosen: list[int], count: int) -> list[tuple]:
        return [scoring.start_of(situation) for key in chosen
                for situation in world.situations(key)][:count]

    validation_keys, test_keys = scoring.held_out_keys(scored, protocol)
    return (training, len(world.starts),
            starts_of(validation_keys, protocol["validation_situations"]),
            starts_of(test_keys, protocol["test_situations"]))


def starts(folder: Path) -> dict:
    """The narrow track's starts under the folder's ``protocol.json``: how many of its test
    starts are distinct and how many also start a validation situation, how many starts the
    track has and how many validation and test take, the median distance from a test start to
    the nearest validation start facing the same way, and the training start's distance to
    the nearest test start (m)."""
    protocol = json.loads((folder / "protocol.json").read_text(encoding="utf-8"))
    training, track_starts, validation, test = _narrow_starts(protocol)
    validation = set(validation)

    def nearest(start: tuple, among: set) -> float:  # facing the same way
        return min((np.hypot(start[0] - x, start[1] - y) for x, y, heading in among
                    if abs(np.angle(np.exp(1j * (heading - start[2])))) < 0.1), default=np.inf)

    return {"distinct": len(set(test)),
            "shared": sum(start in validation for start in test),
            "track": track_starts, "used": len(validation | set(test)),
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


# The second round (docs/results.md, "The second round"; kind ``baseline_round2``): its folder
# holds the tables, its protocol.json and its saved controllers, and no scenarios.json; its
# scenarios are the shipped ones of the names its runs give.


def round2_starts(folder: Path) -> dict:
    """The narrow track's starts under the second round's own ``protocol.json`` (whose
    validation and test situations drew their starts from the same poses): how far apart the
    track's candidate starts lie along a lane (m, ``start_anywhere``), how many test starts
    there are, how many are distinct, how many are also a validation start, and per method
    and budget the mean test fitness (``situations.csv``, over seeds and situations) of the
    test situations whose start is no validation start."""
    from enn_traffic.roads.network import ANYWHERE_SPACING_M

    protocol = json.loads((folder / "protocol.json").read_text(encoding="utf-8"))
    _, _, validation, test = _narrow_starts(protocol)
    shared = [start in set(validation) for start in test]
    situations = pd.read_csv(folder / "situations.csv")
    narrow = situations[situations["scenario"] == "navigation_narrow"]
    others = narrow[~narrow["situation"].map(dict(enumerate(shared))).astype(bool)]
    means = others.groupby(["method", "budget_steps"])["test_fitness"].mean()
    return {"spacing": float(ANYWHERE_SPACING_M), "test": len(test),
            "distinct": len(set(test)), "shared": sum(shared),
            "without_shared": [{"method": method, "budget_steps": int(budget),
                                "test_fitness": float(mean)}
                               for (method, budget), mean in means.items()]}


def round2_settings(folder: Path) -> dict:
    """What the second round ran under beyond its ``protocol.json``: the test keys the
    comparison's first round read (the key ledger, :mod:`enn_traffic.core.keys`; the folder's
    own test keys must be the second round's allocation), and each scenario of its runs
    (``comparison.csv``) as the package ships it: a step's length (s), the step cap, and how
    many validation and test situations one key gives (of
    :func:`~enn_traffic.experiments.gradient_rl.scoring.scoring_scenario`)."""
    from enn_traffic.config.shipped import shipped_scenario
    from enn_traffic.core import keys
    from enn_traffic.envs.rangefinder import rangefinder_world
    from enn_traffic.experiments.gradient_rl import scoring

    protocol = json.loads((folder / "protocol.json").read_text(encoding="utf-8"))
    if protocol["test_key"] not in keys.COMPARISON_SECOND_ROUND_TEST.keys:
        raise ValueError(f"{folder}: test keys from {protocol['test_key']:,} are not the "
                         "second round's")
    scenarios = {}
    for name in sorted(set(_runs(folder)["scenario"])):
        scenario = shipped_scenario(name)
        world = rangefinder_world(scoring.scoring_scenario(scenario))
        scenarios[name] = {"dt": float(scenario.vehicle.dt),
                           "max_steps": int(scenario.episode.max_steps),
                           "situations_per_key": len(world.situations(protocol["test_key"]))}
    return {"first_round_test_key": keys.COMPARISON_FIRST_ROUND_TEST.start,
            "scenarios": scenarios}


def round2_networks(folder: Path) -> dict:
    """The networks of the second round's saved controllers (``controllers/``, one a run of
    ``comparison.csv``), per scenario and method: the readings they take and their hidden
    layers' sizes (the GA's controller file's layer sizes; PPO's and SAC's
    :class:`~enn_traffic.experiments.gradient_rl.policy.NumpyPolicy`'s linear layers), the
    same for every run of them."""
    from enn_traffic.experiments.gradient_rl.campaign import controller_path
    from enn_traffic.experiments.gradient_rl.policy import NumpyPolicy
    from enn_traffic.runs.controller import Controller

    found: dict[str, dict[str, dict]] = {}
    for run in _runs(folder)[round_protocol.RUN_KEYS].itertuples(index=False):
        path = controller_path(folder, *run)
        if run.method == "GA":
            sizes = list(Controller.load(path).layer_sizes)
        else:
            linear = [a for kind, a, _ in NumpyPolicy.load(path).layers if kind == "linear"]
            sizes = [linear[0].shape[0], *(a.shape[1] for a in linear)]
        network = {"inputs": int(sizes[0]), "hidden": [int(size) for size in sizes[1:-1]]}
        if found.setdefault(run.scenario, {}).setdefault(run.method, network) != network:
            raise ValueError(f"{path}: a network of {sizes}, unlike its method's other runs")
    return found


def round2_levels(folder: Path) -> dict:
    """The level of the second round's intervals, which no file of it records, read back
    from its tables: the seeds' Student's t intervals (``comparison_summary.csv``, over the
    runs' test fitness in ``comparison.csv``) give theirs (the same, to 6 places, for every
    row with a spread); the Welch intervals of ``comparison_differences.csv``
    (:func:`~enn_traffic.report.stats.welch_contrast`) and each run's bootstrap interval over
    its test situations (``situations.csv``; :func:`~enn_traffic.report.stats.
    bootstrap_interval`, seeded by the run's seed, as the round drew it) have that level where
    every row of theirs is what it gives at it, else ``None``."""
    from scipy import stats as scipy_stats

    from enn_traffic.report.stats import bootstrap_interval, welch_contrast

    group = ["scenario", "method", "budget_steps"]
    runs = _runs(folder)
    fitness = {key: values["test_fitness"].to_numpy() for key, values in runs.groupby(group)}
    found = set()
    for row in pd.read_csv(folder / "comparison_summary.csv").itertuples():
        values = fitness[row.scenario, row.method, row.budget_steps]
        if len(values) < 2 or values.std() == 0:
            continue
        sem = values.std(ddof=1) / np.sqrt(len(values))
        half = (row.seeds_high - row.seeds_low) / 2
        found.add(round(float(2 * scipy_stats.t.cdf(half / sem, len(values) - 1) - 1), 6))
    if len(found) != 1:
        raise ValueError(f"{folder}: the seeds' intervals have levels {sorted(found)}")
    level = found.pop()
    welch = all(np.allclose(welch_contrast([fitness[row.scenario, row.method, row.budget_steps],
                                            fitness[row.scenario, "GA", row.ga_budget_steps]],
                                           [1, -1], level),
                            (row.minus_ga, row.minus_ga_low, row.minus_ga_high))
                for row in pd.read_csv(folder / "comparison_differences.csv").itertuples())
    situations = pd.read_csv(folder / "situations.csv").sort_values("situation")
    lives = {key: values["test_fitness"].to_numpy()
             for key, values in situations.groupby(round_protocol.RUN_KEYS)}
    bootstrap = all(np.allclose(bootstrap_interval(
                        lives[row.scenario, row.method, row.budget_steps, row.seed],
                        np.random.default_rng(row.seed), level=level),
                                (row.test_fitness_low, row.test_fitness_high))
                    for row in runs.itertuples())
    return {"seeds": level, "differences": level if welch else None,
            "situations": level if bootstrap else None}
