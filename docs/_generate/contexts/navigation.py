"""Context part: navigation (docs/_generate/README.md): docs/results.md's introduction, its
navigation, dynamic-vehicle and lane-keeping sections, and the README's rows of the same
experiments, from the tables ``reproduce`` wrote into ``results/paper`` (Figs. 7-9, the
generalisation, Fig. 11, Tables 1-2, lane keeping), their facts files, ``summary.json``'s
wall times, and the settings the package declares (the arena family, the shipped scenarios,
the paper's own numbers). Its names are this part's own: ``navigation``, ``dynamic`` and
``lane_keeping``."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd

from enn_traffic.config.shipped import shipped_scenario
from enn_traffic.experiments.facts import read as read_facts
from enn_traffic.experiments.families import ARENA, SUMO
from enn_traffic.experiments.navigation import REACHED_B
from enn_traffic.report.paper import PAPER_TABLE1, PAPER_TABLE2


def _span(values) -> dict:
    """The lowest and highest of some values (a template writes ``low–high``, or one value
    where they are equal)."""
    values = [_native(v) for v in values]
    return {"low": min(values), "high": max(values)}


def _native(value):
    """A table's cell as Python writes it: an int where it is whole."""
    value = value.item() if isinstance(value, np.generic) else value
    return int(value) if isinstance(value, float) and value.is_integer() else value


def _records(table: pd.DataFrame) -> list[dict]:
    return [{k: _native(v) for k, v in row.items()} for row in table.to_dict("records")]


def _pattern(matrix: np.ndarray) -> dict:
    """Table 1's pattern as a reader reads it off the matrix: the diagonal's mean, the rest's,
    and the rows whose diagonal entry is above every other entry of the row."""
    size = len(matrix)
    off = ~np.eye(size, dtype=bool)
    top = [bool(matrix[i, i] > np.delete(matrix[i], i).max()) for i in range(size)]
    return {"diagonal": float(np.diag(matrix).mean()), "rest": float(matrix[off].mean()),
            "rows_on_top": sum(top), "rows": size}


def _summary(paper: Path) -> dict:
    """summary.json: each experiment's wall time and the commit that made it."""
    return json.loads((paper / "summary.json").read_text(encoding="utf-8"))


def navigation(paper: Path) -> dict:
    fig7 = pd.read_csv(paper / "fig7.csv")
    fig8 = pd.read_csv(paper / "fig8.csv")
    fig9 = pd.read_csv(paper / "fig9.csv")
    reached = fig7["reached_B_generation"].dropna().astype(int)
    capped = fig8["capped_generation"].dropna().astype(int)
    table = pd.read_csv(paper / "generalization.csv")
    unseen = table[~table["seen"] & (table["tracks"] != "training")]
    trainings = list(dict.fromkeys(table["trained_on"]))
    pairs = {kind: {name: {"capped": int(group["capped"].sum()), "pairs": len(group)}
                    for name, group in unseen[unseen["tracks"] == kind].groupby(
                        "trained_on", sort=False)}
             for kind in ("validation", "test")}
    tracks = {kind: list(dict.fromkeys(table[table["tracks"] == kind]["track"]))
              for kind in ("validation", "test")}
    seeds = int(table["seed"].nunique())

    def on_track(name: str, track: str) -> dict:
        rows = table[(table["trained_on"] == name) & (table["track"] == track)]
        missed = rows[~rows["capped"]]
        return {"capped": int(rows["capped"].sum()), "seeds": len(rows),
                "missed_steps": sorted(int(s) for s in missed["steps"])}

    own = table[table["tracks"] == "training"]
    mixed = trainings[-1]
    own_mixed = own[own["trained_on"] == mixed]
    return {
        "reached_B": REACHED_B,
        "reached_B_wide": 2 * REACHED_B,  # B on the wide track, as fig8 counts it
        "population": shipped_scenario("navigation_narrow").ga.population_size,
        "generations": int(fig7["generations"].max()),
        "seeds": len(fig7),
        "fig7": {"seeds": len(fig7), "reached": len(reached), "reached_at": _span(reached),
                 "passed_A_at": _span(fig7["passed_A_generation"]),
                 "best": _span(fig7["max_best_fitness"])},
        "fig8": {"seeds": len(fig8),
                 "cap": shipped_scenario("navigation_wide").episode.max_steps,
                 "capped_at": [int(g) for g in capped],
                 "at_once": int((fig8["reached_B_generation"] == 0).sum()),
                 "capped_at_once": [int(s) for s in fig8[fig8["capped_generation"] == 0]["seed"]]},
        "fig9": _records(fig9),
        "generalization": {
            "trainings": [{"name": name, "pairs": pairs["test"][name],
                           "validation": pairs["validation"][name],
                           "test_tracks": [on_track(name, t) for t in tracks["test"]]}
                          for name in trainings],
            "seeds": seeds, "tracks": {kind: len(names) for kind, names in tracks.items()},
            "cap": int(unseen["cap"].max()),
            "share": {name: pairs["test"][name]["capped"] / pairs["test"][name]["pairs"]
                      for name in trainings},
            "mixed": {track: on_track(mixed, track)
                      for track in tracks["validation"] + tracks["test"]},
            # the mixed controllers on the validation tracks but the authors' narrow one
            "mixed_others": {"count": len(tracks["validation"]) - 1, "capped": _span(
                on_track(mixed, t)["capped"] for t in tracks["validation"]
                if t != "unseen_narrow")},
            "mixed_tracks": int(own_mixed["track"].nunique()),
            "mixed_own": {"capped": int(own_mixed["capped"].sum()), "pairs": len(own_mixed),
                          "cap": int(own_mixed["cap"].max())},
        },
    }


def dynamic(paper: Path) -> dict:
    fig11 = pd.read_csv(paper / "fig11.csv")
    rise = fig11.groupby("strategy")[["rise", "mean_rise", "held_out_rise"]].median()
    by_strategy = {int(s): group for s, group in fig11.groupby("strategy")}
    table1 = pd.read_csv(paper / "table1.csv").set_index("training_strategy")
    matrix = table1.to_numpy()
    strategies = [int(s) for s in table1.index]
    rows = []
    for i, strategy in enumerate(strategies):
        others = [j for j in range(len(strategies)) if j != i]
        nxt = max(others, key=lambda j: matrix[i, j])
        rows.append({"strategy": strategy, "own": float(matrix[i, i]),
                     "next": float(matrix[i, nxt]), "next_strategy": strategies[nxt],
                     "cells": {strategies[j]: float(matrix[i, j]) for j in range(len(strategies))}})
    closest = min(rows, key=lambda r: r["own"] - r["next"])["strategy"]
    unseen = pd.read_csv(paper / "table1_seed5000_matrix.csv", index_col=0)
    lives = pd.read_csv(paper / "table1_seed5000.csv")
    table2 = pd.read_csv(paper / "table2.csv")
    runs = pd.read_csv(paper / "table2_runs.csv")
    names = [c for c in table2.columns if c.startswith("strategy_")]
    chosen = next(int(seed) for seed, group in runs.groupby("seed")
                  if np.allclose(group[names].fillna(-1).to_numpy(),
                                 table2[names].fillna(-1).to_numpy()))
    last = runs[runs["iteration"] == runs["iteration"].max()]
    other_ends = [{"seed": int(row.seed),
                   "worst": float(min(getattr(row, n) for n in names)),
                   "worst_strategy": int(min(names, key=lambda n: getattr(row, n))
                                         .removeprefix("strategy_"))}
                  for row in last.itertuples() if int(row.seed) != chosen]
    threshold = round(ARENA.threshold)
    last_row = {int(n.removeprefix("strategy_")): float(table2[n].iloc[-1]) for n in names}
    table1_own = {r["strategy"]: r["own"] for r in rows}

    def unaccepted(folder: Path) -> list[dict]:
        every = pd.read_csv(folder / "table2_runs.csv")
        return _records(every[~every["reached_threshold"]][["seed", "iteration"]])

    summary = _summary(paper)
    paper_diagonal = _pattern(np.array(PAPER_TABLE1, dtype=float))
    paper_averages = [sum(row) / len(row) for row in PAPER_TABLE2]
    arena = shipped_scenario(ARENA.name(1))
    return {
        "population": arena.ga.population_size,
        "situations_per_chromosome": arena.traffic.episodes,
        "hidden": arena.network.hidden[0],
        "incremental_hidden": ARENA.incremental_hidden[0],
        "test_situations": ARENA.test_situations,
        "table_situations": ARENA.table_situations,
        "threshold": threshold,
        "max_generations": {"arena": ARENA.incremental_max_generations,
                            "sumo": SUMO.incremental_max_generations},
        "paper": {"table1_ratio": paper_diagonal["diagonal"] / paper_diagonal["rest"],
                  "table2_share": paper_averages[-1] / paper_averages[0]},
        "fig11": {
            "generations": int(fig11["generations"].max()),
            "strategies": len(by_strategy), "seeds": int(fig11["seed"].nunique()),
            "rise": {int(s): float(r.rise) for s, r in rise.iterrows()},
            "mean_rise": {int(s): float(r.mean_rise) for s, r in rise.iterrows()},
            "held_out_rise": {int(s): float(r.held_out_rise) for s, r in rise.iterrows()},
            "runs_rise": {s: _span(g["rise"]) for s, g in by_strategy.items()},
            "last_held_out": {s: _span(g["last5_mean_held_out"]) for s, g in by_strategy.items()},
            "last_best": {s: _span(g["last5_mean_best"]) for s, g in by_strategy.items()},
        },
        "table1": {**_pattern(matrix), "rows_detail": rows, "closest": closest,
                   "seconds": summary["table1"]["seconds"],
                   "seed5000": {**_pattern(unseen.to_numpy()),
                                "situations": int(lives.groupby(["controller", "scenario"])
                                                  .size().min())},
                   "spread": read_facts(paper, "table1")},
        "table2": {
            "first": float(table2["average"].iloc[0]), "last": float(table2["average"].iloc[-1]),
            "iterations": _records(table2),
            "last_row": last_row,
            "kept": bool((table2[names].iloc[-1] > threshold).all()),
            "seed": chosen, "seeds": int(runs["seed"].nunique()),
            "evolved": [int(g) for g in runs.groupby("seed")["generations"].sum()],
            "max_generations": ARENA.incremental_max_generations,
            "other_ends": other_ends,
            "below": [end for end in other_ends if end["worst"] < threshold],
            "city_iterations": int(pd.read_csv(paper / "city" / "table2_runs.csv")
                                   ["iteration"].max()),
            # the strategies on whose traffic Table 2's last controller lives longer than
            # Table 1's specialist, and those on which it does not
            "beats": [s for s, v in last_row.items() if v > table1_own[s]],
            "beaten_by": [s for s, v in last_row.items() if v <= table1_own[s]],
            "unaccepted": {"arena": unaccepted(paper), "sumo": unaccepted(paper / "sumo"),
                           "city": unaccepted(paper / "city")},
        },
    }


def lane_keeping(paper: Path) -> dict:
    table = pd.read_csv(paper / "lane_keeping.csv")
    facts = read_facts(paper, "lane_keeping")
    roads = list(dict.fromkeys(table["road"]))
    trainings = list(dict.fromkeys(table["trained_on"]))
    noises = sorted(table["noise_m"].unique())
    seeds = int(table["seed"].nunique())
    kept = table.groupby(["trained_on", "noise_m", "road"], sort=False)[
        "kept_whole_episode"].sum()
    per_seed = table.groupby(["trained_on", "noise_m", "seed"])["kept_whole_episode"].sum()
    drawn, one = trainings[-1], trainings[0]
    fresh = table[(table["trained_on"] == drawn) & table["fresh"]]
    one_kept = table[(table["trained_on"] == one) & table["kept_whole_episode"]]
    tightest = one_kept.loc[one_kept["road"].map(
        lambda r: facts["roads"][r]["peak_curvature"]).idxmax()]
    drawn_kept = table[(table["trained_on"] == drawn) & table["kept_whole_episode"]]
    geometry = facts["roads"]
    sines = [g for g in geometry.values() if g["kind"] == "sine"]
    circles = [g for g in geometry.values() if g["kind"] == "circle"]
    scenario = shipped_scenario(one).lane_keeping
    draw = shipped_scenario(drawn).lane_keeping
    summary = _summary(paper)["lane_keeping"]
    return {
        "seconds": summary["seconds"],
        "lookahead": [_native(d) for d in scenario.lookahead_m],
        "population": shipped_scenario(one).ga.population_size,
        "generations": {name: shipped_scenario(name).ga.generations for name in trainings},
        "training_s": {name: _span(table[table["trained_on"] == name]["training_wall_s"])
                       for name in trainings},
        "seeds": seeds, "noise": _native(max(noises)),
        "lane_width": scenario.lane_width,
        "drawn": {"roads": draw.episodes, "noise": draw.noise_m,
                  **{name: list(getattr(draw.draw, name))
                     for name in ("amplitude", "period", "radius")}},
        "cap": facts["episode_steps"], "cap_m": facts["episode_m"],
        "roads": [{"name": road, "fresh": bool(table[table["road"] == road]["fresh"].iloc[0]),
                   **geometry[road],
                   "kept": {name: int(kept[name, noises[0], road]) for name in trainings},
                   "same_with_noise": all(kept[name, n, road] == kept[name, noises[0], road]
                                          for name in trainings for n in noises)}
                  for road in roads],
        "road_count": len(roads), "fresh_count": int(table[table["fresh"]]["road"].nunique()),
        "every": int((per_seed[drawn].groupby("seed").min() == len(roads)).sum()),
        "all_kept": bool(table[table["trained_on"] == drawn]["kept_whole_episode"].all()),
        "fresh_kept": int(fresh.groupby("seed")["kept_whole_episode"].all().sum()),
        "one_road": _span(per_seed[one]),
        "offset": _span(table[table["trained_on"] == drawn]["mean_abs_offset_m"]),
        "drawn_peak": max(geometry[r]["peak_curvature"] for r in drawn_kept["road"]),
        "drawn_sharpest": min(geometry[r]["sharpest_radius"] for r in drawn_kept["road"]),
        "sharpest_sine": min(g["sharpest_radius"] for g in sines),
        "smallest_circle": min(g["radius"] for g in circles),
        "training_road": geometry[roads[0]],
        "tightest_one_road": {"seed": int(tightest["seed"]), **geometry[tightest["road"]]},
        "one_road_left": _span(table[(table["trained_on"] == one)
                                     & ~table["kept_whole_episode"]]["steps_in_lane"]),
    }


def context(root: Path) -> dict:
    paper = root / "results" / "paper"
    return {"navigation": navigation(paper), "dynamic": dynamic(paper),
            "lane_keeping": lane_keeping(paper)}
