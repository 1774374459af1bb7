"""README.md's command synopsis, from the command line's parser, and its city example, from
the committed tables of the commands it shows
(``results/readme_example/``): the run's ``generations.csv`` and its best controller's
``evaluate`` tables in replay, in closed loop and on the same roads without traffic
(``city_cologne3_no_traffic.toml`` there). The README's timings come from the bench tables
(:mod:`contexts.bench`)."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import pandas as pd

# the outcomes in the order the table lists them; any other after them, by name
OUTCOMES = ["left network", "collision"]


def evaluation(table: pd.DataFrame) -> dict:
    """The means of an ``evaluate`` table's columns, its situations and its outcomes with
    their counts."""
    counts = table["outcome"].value_counts()
    order = sorted(counts.index, key=lambda o: (OUTCOMES.index(o) if o in OUTCOMES
                                                else len(OUTCOMES), o))
    means = table.mean(numeric_only=True).to_dict()
    return {"mean": means, "situations": len(table),
            "outcomes": [{"outcome": o, "count": int(counts[o])} for o in order]}


def synopsis(width: int = 96) -> list[str]:
    """Each command's usage line as ``enn-traffic COMMAND --help`` prints it (without
    ``-h`` and the ``usage:`` prefix), in the order ``enn-traffic --help`` lists them."""
    from enn_traffic.cli import build_parser

    parser = build_parser()
    commands = next(action for action in parser._actions
                    if isinstance(action, argparse._SubParsersAction))
    lines = []
    for command in commands.choices.values():
        formatter = argparse.HelpFormatter(command.prog, width=width)
        formatter.add_usage(None, [action for action in command._actions
                                   if not isinstance(action, argparse._HelpAction)],
                            command._mutually_exclusive_groups, prefix="")
        lines.append(formatter.format_help().rstrip("\n"))
    return lines


def experiments(root: Path) -> list[str]:
    """The experiments whose results the committed reproduction holds (its ``summary.json``),
    in the order ``reproduce`` runs them."""
    from enn_traffic.experiments import EXPERIMENTS

    summary = json.loads((root / "results" / "paper" / "summary.json").read_text(encoding="utf-8"))
    return [name for name in EXPERIMENTS if name in summary]


def context(root: Path) -> dict:
    folder = root / "results" / "readme_example"
    generations = pd.read_csv(folder / "generations.csv")
    best = generations["best_fitness"]
    start = generations["traffic_at_start"]
    from enn_traffic.experiments import EXPERIMENTS

    return {"readme": {"commands": synopsis(),
                       "experiments": experiments(root), "every_experiment": len(EXPERIMENTS),
                       "city": {
        "generations": len(generations),
        "first_best": best.iloc[0], "last_best": best.iloc[-1],
        "traffic_low": start.min(), "traffic_high": start.max(),
        "replay": evaluation(pd.read_csv(folder / "city_replay.csv")),
        "closed_loop": evaluation(pd.read_csv(folder / "city_closed.csv")),
        "no_traffic": evaluation(pd.read_csv(folder / "city_no_traffic.csv"))}}}
