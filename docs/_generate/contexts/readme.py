"""README.md's city example, from the committed tables of the commands it shows
(``results/readme_example/``): the run's ``generations.csv`` and its best controller's
``evaluate`` tables in replay, in closed loop and on the same roads without traffic
(``city_cologne3_no_traffic.toml`` there). The README's timings come from the bench tables
(:mod:`contexts.bench`)."""

from __future__ import annotations

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


def context(root: Path) -> dict:
    folder = root / "results" / "readme_example"
    generations = pd.read_csv(folder / "generations.csv")
    best = generations["best_fitness"]
    start = generations["traffic_at_start"]
    return {"readme": {"city": {
        "generations": len(generations),
        "first_best": best.iloc[0], "last_best": best.iloc[-1],
        "traffic_low": start.min(), "traffic_high": start.max(),
        "replay": evaluation(pd.read_csv(folder / "city_replay.csv")),
        "closed_loop": evaluation(pd.read_csv(folder / "city_closed.csv")),
        "no_traffic": evaluation(pd.read_csv(folder / "city_no_traffic.csv"))}}}
