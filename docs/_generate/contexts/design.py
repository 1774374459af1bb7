"""docs/design.md: the layers (the package's folders, each described by its docstring), the
traffic keys' ledger, and generations.csv's columns, as the package declares them; and what
a change costs, as counted on scratch branches (``results/house/change_tasks.csv``)."""

from __future__ import annotations

import importlib
import re
from pathlib import Path

import pandas as pd

from enn_traffic import LAYERS
from enn_traffic.core import keys
from enn_traffic.runs.generations_csv import COLUMNS

BILLION = 1_000_000_000


def summary(docstring: str) -> str:
    """A docstring's first paragraph as Markdown: one line, reST roles as code."""
    first = " ".join(docstring.split("\n\n")[0].split())
    return re.sub(r":\w+:`~?([^`]+)`", lambda m: f"`{m[1].rsplit('.', 1)[-1]}`", first).replace(
        "``", "`")


def key(number: int) -> str:
    """A traffic key as the ledger writes it: 6·10⁹ + 540,000."""
    whole, rest = divmod(number, BILLION)
    head = "0" if whole == 0 else "10⁹" if whole == 1 else f"{whole}·10⁹"
    return head if rest == 0 else f"{rest:,}" if whole == 0 else f"{head} + {rest:,}"


def bench_ab(table: pd.DataFrame) -> dict:
    """An A/B of two codes: each row's median rate (vehicle-steps, or learner-steps where the
    workload counts those) after over before, and whether the two codes' ranges over the
    rounds overlap."""
    before = table["code"].iloc[0]
    if "learner_steps_per_s" in table:
        table = table.assign(vehicle_steps_per_s=table["vehicle_steps_per_s"].fillna(
            table["learner_steps_per_s"]))
    rows = []
    for (workload, implementation, threads), group in table.groupby(
            ["workload", "implementation", "threads"], sort=False):
        rates = group.groupby("code")["vehicle_steps_per_s"]
        low, high, median = rates.min(), rates.max(), rates.median()
        after = next(code for code in median.index if code != before)
        rows.append({"workload": workload, "implementation": implementation,
                     "threads": int(threads), "ratio": median[after] / median[before],
                     "overlap": bool(low[after] <= high[before] and low[before] <= high[after]),
                     "spread": float(((high - low) / median).max())})
    return {"before": before, "rounds": int(table["round"].nunique()), "rows": rows,
            "overlapping": sum(row["overlap"] for row in rows)}


def context(root: Path) -> dict:
    layers = [{"name": name, "summary": summary(importlib.import_module(
        f"enn_traffic.{name}").__doc__)} for name in LAYERS]
    ranges = [{"name": name, "first": key(r.keys.start), "use": r.read_by}
              for name, r in sorted(keys.RANGES.items(), key=lambda item: item[1].start)]
    allocations = [{"name": name, "first": key(a.keys.start),
                    "last": key(a.keys[-1]), "read_by": a.read_by}
                   for name, a in sorted(keys.ALLOCATIONS.items(), key=lambda i: i[1].start)]
    tasks = pd.read_csv(root / "results" / "house" / "change_tasks.csv").to_dict("records")
    house = root / "results" / "house"
    return {"bench_ab": bench_ab(pd.read_csv(house / "bench_ab.csv")),
            "bench_channels": bench_ab(pd.read_csv(house / "bench_channels_ab.csv")),
            "bench_distances": bench_ab(pd.read_csv(house / "bench_distances_ab.csv")),
            "bench_today": bench_ab(pd.read_csv(house / "bench_today_ab.csv")),
            "change_tasks": tasks, "layers": layers, "key_ranges": ranges,
            "key_allocations": allocations,
            "generations_columns": [{"name": name, "meaning": " ".join(
                function.__doc__.split())} for name, function in COLUMNS.items()]}
