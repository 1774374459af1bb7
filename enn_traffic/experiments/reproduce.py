"""``enn-traffic reproduce``: every experiment of the paper into one folder, with summary.md.

Each experiment's wall time, date and the code that ran it (commit and source digest,
:mod:`enn_traffic.core.provenance`) are kept in ``summary.json``, so a call with ``--only``
updates its own experiments and summary.md still lists every one done so far; each line of
summary.md is read from the tables the experiment wrote (:func:`enn_traffic.experiments.
summary_lines`), so it says what they say now.
"""

from __future__ import annotations

import json
import time
from datetime import UTC, datetime
from pathlib import Path
from typing import TYPE_CHECKING

from tqdm import tqdm

from enn_traffic.core.errors import InputError
from enn_traffic.core.io import write_csv, write_text
from enn_traffic.core.progress import terminal
from enn_traffic.core.provenance import code_version, commit
from enn_traffic.experiments import EXPERIMENTS, facts, summary_lines
from enn_traffic.experiments.common import executor as runs_on
from enn_traffic.experiments.study import Study
from enn_traffic.report.paper_tables import paper_tables

if TYPE_CHECKING:
    import pandas as pd

    from enn_traffic.experiments.families import Family


def reproduce(out: Path, quick: bool = False, only: list[str] | None = None,
              progress: bool = True, executor: str = "local", address: str | None = None
              ) -> dict:
    """Run the experiments ``only`` (default: all) into ``out``; their independent runs go to
    ``executor`` (local, or ray at ``address``)."""
    names = only or list(EXPERIMENTS)
    unknown = [n for n in names if n not in EXPERIMENTS]
    if unknown:
        raise InputError(f"unknown experiment(s) {', '.join(unknown)}; choose from "
                         f"{', '.join(EXPERIMENTS)}", key="--only")
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    record_path = out / "summary.json"
    records = json.loads(record_path.read_text(encoding="utf-8")) if record_path.exists() else {}
    study = Study(out, quick, progress, runs_on(executor, address))
    bar = tqdm(names, desc="reproduce", unit="experiment", disable=not progress, position=0,
               file=terminal())
    for name in bar:
        bar.set_postfix_str(name)
        # the tree as the experiment starts: its own CSVs would mark it "+changes" after
        tree, code = commit(), code_version()
        started = time.perf_counter()
        lines = EXPERIMENTS[name](study)
        records[name] = {"seconds": round(time.perf_counter() - started, 1),
                         "settings": "quick" if quick else "full", "commit": tree,
                         "code": code,
                         "date": datetime.now(UTC).strftime("%Y-%m-%d %H:%M UTC")}
        write_text(record_path, json.dumps(records, indent=1))
        tqdm.write("\n".join(lines))
    write_summary(out, records)
    facts.write_all(out, "paper")
    for name in names:
        print(f"{name:>16}: {records[name]['seconds']:7.1f} s")
    return records


def write_summary(out: Path, records: dict) -> None:
    """``summary.md`` from every experiment's record (``summary.json``) and the tables in
    ``out``."""
    write_text(out / "summary.md", summary_text(out, records))


def summary_text(out: Path, records: dict) -> str:
    """What :func:`write_summary` writes."""
    done = [n for n in EXPERIMENTS if n in records]
    summary = ["# enn-traffic: reproduction of Eraqi et al. (2016)", ""]
    summary += [f"- {line}" for n in done for line in summary_lines(
        n, Study(out, quick=records[n]["settings"] == "quick", progress=False))]
    summary += ["", "| experiment | settings | commit | code | date | wall time of its last call "
                "[s] |", "|---|---|---|---|---|---|"]
    summary += [f"| {n} | {records[n]['settings']} | {records[n].get('commit') or '-'} | "
                f"{records[n].get('code', '-')} | {records[n].get('date', '-')} | "
                f"{records[n]['seconds']} |" for n in done]
    summary += [f"| {n}/{table} (measured again: {again['why']}) | {records[n]['settings']} | "
                f"{again['commit']} | {again['code']} | {again['date']} | {again['seconds']} |"
                for n in done for table, again in records[n].get("measured_again", {}).items()]
    total = sum(records[n]["seconds"] for n in done)
    summary += [f"| all | | | | | {total:.1f} |", "",
                "A call reuses finished runs made by the same rules (the sources that decide a "
                "run; `code`: a digest of every source of the package): its wall time can be "
                "far below the compute. From an empty folder, the wall times are the "
                "compute.", ""]
    summary += paper_tables(out)
    return "\n".join(summary) + "\n"


def measure_closed_loop_again(paper: Path, family: Family, why: str) -> pd.DataFrame:
    """``closed_loop.csv`` of a reproduce folder ``paper`` measured again from its committed
    Table 1 controllers, when the simulation changed but the controllers did not; the
    family's record in ``summary.json`` says when, at which commit and ``why``
    (:func:`write_summary` lists it, and its line follows the new table)."""
    from enn_traffic.experiments.sumo_family import closed_loop_table
    from enn_traffic.runs.controller import Controller

    tree, code, started = commit(), code_version(), time.perf_counter()
    folder = paper / "controllers" / family.folder / "table1"
    controllers = {s: Controller.load(folder / f"strategy{s}.npz").chromosome
                   for s in family.strategies}
    table = closed_loop_table(family, controllers)
    write_csv(paper / family.folder / "closed_loop.csv", table)
    _record_again(paper, family, "closed_loop.csv", (tree, code, started), why)
    return table


def measure_crowds_again(paper: Path, family: Family, why: str, progress: bool = True
                         ) -> list[str]:
    """A SUMO family's Tables 3–4 of a reproduce folder ``paper`` measured again from its
    committed controllers (the Table 1 winners, the evolved populations), when the
    simulation changed but the controllers did not; recorded as
    :func:`measure_closed_loop_again` records. The summary's new lines."""
    from enn_traffic.experiments.crowds.sumo import (
        SUMO_LEARNING,
        measure,
        saved_crowd_inputs,
        write_tables,
    )

    tree, code, started = commit(), code_version(), time.perf_counter()
    measured = measure(Study(paper, progress=progress), family, SUMO_LEARNING,
                       saved_crowd_inputs(paper, family))
    lines = write_tables(paper / family.folder, measured.situations, measured.learners)
    _record_again(paper, family, "table3.csv, table4.csv", (tree, code, started), why)
    return lines


def _record_again(paper: Path, family: Family, tables: str,
                  made: tuple[str | None, str, float], why: str) -> None:
    """The family's record in ``summary.json``: ``tables`` measured again at ``made``
    (commit, code, start time) because ``why``; summary.md written again, its lines from
    the tables as they are now."""
    tree, code, started = made
    records = json.loads((paper / "summary.json").read_text(encoding="utf-8"))
    record = records[family.folder]
    record.setdefault("measured_again", {})[tables] = {
        "commit": tree, "code": code, "seconds": round(time.perf_counter() - started, 1),
        "date": datetime.now(UTC).strftime("%Y-%m-%d %H:%M UTC"), "why": why}
    write_text(paper / "summary.json", json.dumps(records, indent=1))
    write_summary(paper, records)
