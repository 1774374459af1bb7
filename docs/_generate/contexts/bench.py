"""docs/bench.md (and the README's timings): the committed bench tables of ``results/bench``,
each written by its ``enn-traffic bench --only NAME`` run, the wall times the committed
reproduction keeps in ``results/paper/summary.json``, and the cap on learners in one SUMO
that the scenario schema declares."""

from __future__ import annotations

import json
from pathlib import Path

import pandas as pd

from enn_traffic.config.base import MAX_LEARNERS


def rows(table: pd.DataFrame) -> list[dict]:
    """A table's rows, each a dict of its columns."""
    return table.to_dict("records")


def contention(table: pd.DataFrame) -> dict:
    """The rows, and the default threads' median rates of the second wait policy over the
    first's, per workload."""
    policies = list(dict.fromkeys(table["implementation"]))
    several = table[table["threads"] > 1].set_index(["workload", "implementation"])
    ratios = [{"workload": workload,
               "ratio": several.loc[(workload, policies[1]), "vehicle_steps_per_s"]
               / several.loc[(workload, policies[0]), "vehicle_steps_per_s"]}
              for workload in dict.fromkeys(several.index.get_level_values(0))]
    return {"rows": rows(table), "ratios": ratios, "threads": int(several["threads"].iloc[0])}


def crowd_scale(table: pd.DataFrame) -> dict:
    """The rows, each with its learner count and what the learners add to a step beyond
    SUMO's own, per learner (µs)."""
    table = table.assign(learners=(table["learner_steps"] / table["steps"]).astype(int))
    table["rest_us"] = (1000 * (table["ms_per_step"] - table["sumo_ms_per_step"])
                        / table["learners"])
    return {"rows": rows(table), "workload": table["workload"].iloc[0],
            "steps": int(table["steps"].iloc[0])}


def crowd_marginal(table: pd.DataFrame) -> dict:
    """The rows; per count N the added learner's cost (random networks) over the added
    SUMO-driven vehicle's, in all, in SUMO's step and outside it; what the most learners'
    SSM devices cost; and the most learners driving a trained controller."""
    name = table["implementation"]
    vehicles = table[name.str.contains("SUMO-driven")]
    learners = table[name.str.endswith("learners")]
    ratios = [{"count": int(learner["added_driving"]) + 1,
               **{part: learner[column] / vehicle[column] for part, column in (
                   ("all", "us_per_added_step"), ("sumo", "sumo_us_per_added_step"),
                   ("outside", "outside_us_per_added_step"))}}
              for (_, vehicle), (_, learner) in zip(vehicles.iterrows(), learners.iterrows(),
                                                    strict=True)]
    bare = table[name.str.endswith("no SSM devices")].iloc[0]
    trained = table[name.str.endswith("a trained controller")].iloc[0]
    equipped, vehicle = learners.iloc[-1], vehicles.iloc[-1]
    ssm_us = equipped["sumo_us_per_added_step"] - bare["sumo_us_per_added_step"]
    return {"rows": rows(table), "ratios": ratios, "workload": table["workload"].iloc[0],
            "steps": int(table["steps"].iloc[0]), "runs": int(table["runs"].iloc[0]),
            "most": equipped.to_dict(), "vehicle": vehicle.to_dict(),
            "ssm": {"us": ssm_us, "share": ssm_us / equipped["sumo_us_per_added_step"],
                    "bare_us": bare["sumo_us_per_added_step"]},
            "trained": {**trained.to_dict(),
                        "ratio": trained["us_per_added_step"] / vehicle["us_per_added_step"]}}


def checkouts(table: pd.DataFrame) -> dict:
    """A ``python -m enn_traffic.bench.checkouts`` table: per checkout and round, the cost of a
    learner per step (the run of one learner taken off), in all, in SUMO's step and by part
    (µs); per checkout the medians over the rounds, and after over before."""
    figures = {}
    for label, runs in table.groupby("checkout", sort=False):
        many, one = runs[runs["learners"] > 1], runs[runs["learners"] == 1]
        per = 1e6 / ((many["learners"].to_numpy() - 1) * many["steps"].to_numpy())
        # the whole, SUMO's step, and each part the CSV times (``<part>_seconds``)
        columns = {"all": "seconds", **{column.removesuffix("_seconds"): column
                                        for column in table.columns
                                        if column.endswith("_seconds")}}
        each = {name: (many[column].to_numpy() - one[column].to_numpy()) * per
                for name, column in columns.items()}
        figures[label] = {
            "commit": runs["commit"].iloc[0], "rounds": len(many),
            "learners": int(many["learners"].iloc[0]), "steps": int(many["steps"].iloc[0]),
            "ms_per_step": 1000 * float((many["seconds"] / many["steps"]).median()),
            "entries_per_learner_step": float((many["entries"] / many["learners"]
                                               / many["steps"]).median()),
            **{name: float(pd.Series(values).median()) for name, values in each.items()},
            "all_min": float(each["all"].min()), "all_max": float(each["all"].max())}
    before, after = figures["before"], figures["after"]
    return {"before": before, "after": after,
            "ratio": after["ms_per_step"] / before["ms_per_step"]}


def recording(table: pd.DataFrame) -> dict:
    """The GA's generations and the environment's life, each recorded over the whole cap
    first (``whole``) and as far as the lives reach (``reach``)."""
    def arms(prefix: str) -> dict:
        rows = table[table["workload"].str.startswith(prefix)]
        whole = rows["implementation"].str.startswith("the whole cap")
        return {"whole": rows[whole].iloc[0].to_dict(), "reach": rows[~whole].iloc[0].to_dict()}

    return {"generations": arms("sumo default cap:"), "life": arms("sumo env:")}


def reproduce_quick(table: pd.DataFrame) -> dict:
    """Each experiment's row, and the whole command's seconds."""
    whole = table["implementation"] == "the whole command"
    return {"rows": rows(table[~whole]), "whole": float(table[whole]["seconds"].iloc[0])}


def context(root: Path) -> dict:
    folder = root / "results" / "bench"

    def read(name: str) -> pd.DataFrame:
        return pd.read_csv(folder / f"{name}.csv")

    summary = json.loads((root / "results" / "paper" / "summary.json").read_text(encoding="utf-8"))
    return {"bench": {
        "first_run": rows(read("first_run_issue62")),
        "contention": contention(read("contention_issue62")),
        "reproduce_quick": reproduce_quick(read("reproduce_quick_issue62")),
        "bench_quick": rows(read("bench_quick_issue62"))[0],
        "test_suite": rows(read("test_suite_issue62")),
        "fresh": rows(read("fresh_issue62")),
        "sumo_step": rows(read("sumo_step_issue60")),
        "published": rows(read("published_issue60")),
        "crowd_scale": crowd_scale(read("crowd_scale_issue83")),
        "crowd_ray": rows(read("crowd_ray_issue63")),
        "crowd_marginal": crowd_marginal(read("crowd_marginal_issue83")),
        "crowd_reentry": checkouts(read("crowd_reentry_issue83")),
        "recording": recording(read("recording_issue50")),
        "sb3": rows(read("sb3_issue52")),
        "summary": summary, "max_learners": MAX_LEARNERS}}
