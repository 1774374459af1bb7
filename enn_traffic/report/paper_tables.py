"""The paper's Tables 1–4 beside the reproduced ones, as Markdown for summary.md."""

from __future__ import annotations

from pathlib import Path

import pandas as pd

from enn_traffic.report.paper import PAPER_TABLE1, PAPER_TABLE2, PAPER_TABLE3, PAPER_TABLE4


def _pair(paper, here) -> str:
    return f"{paper:g} / {here:g}"


def _table1(path: Path, title: str) -> list[str]:
    table = pd.read_csv(path)
    lines = [f"### {title}: paper / here (fitness, steps)", "",
             "| trained \\ deployed | 1 | 2 | 3 | 4 |", "|---|---|---|---|---|"]
    for i, row in table.iterrows():
        cells = [_pair(PAPER_TABLE1[i][j], round(row[f"deploy_{j + 1}"])) for j in range(4)]
        lines.append(f"| {int(row['training_strategy'])} | " + " | ".join(cells) + " |")
    return [*lines, ""]


def _table2(path: Path, title: str) -> list[str]:
    table = pd.read_csv(path)
    lines = [f"### {title}: paper / here (fitness, steps; the paper has 3 iterations)", "",
             "| iteration | 1 | 2 | 3 | 4 | average |", "|---|---|---|---|---|---|"]
    for i, row in table.iterrows():
        paper = PAPER_TABLE2[i] if i < len(PAPER_TABLE2) else []
        cells = []
        for j in range(4):
            here = row[f"strategy_{j + 1}"]
            if pd.isna(here):
                cells.append("")
            else:
                cells.append(_pair(paper[j], round(here)) if j < len(paper)
                             else f"– / {round(here)}")
        average = sum(paper) / len(paper) if paper else None
        cells.append(_pair(round(average, 1), round(row["average"])) if average
                     else f"– / {round(row['average'])}")
        lines.append(f"| {int(row['iteration'])} | " + " | ".join(cells) + " |")
    return [*lines, ""]


def _rates(path: Path, title: str, paper) -> list[str]:
    table = pd.read_csv(path)
    lines = [f"### {title}: collisions per second, paper (its count) / here (per vehicle)", "",
             "| strategy | initial | after |", "|---|---|---|"]
    for i, row in table.iterrows():
        lines.append(f"| {int(row['strategy'])} | {_pair(paper[i][0], row.iloc[1])} | "
                     f"{_pair(paper[i][1], row.iloc[2])} |")
    return [*lines, ""]


def paper_tables(out: Path) -> list[str]:
    """Markdown for every reproduced table found in ``out``."""
    sections = []
    families = (("", "arena"), ("sumo", "SUMO traffic"), ("city", "Cologne city traffic"))
    for folder, label in families:
        base = out / folder
        if (base / "table1.csv").exists():
            sections += _table1(base / "table1.csv", f"Table 1, {label}")
        if (base / "table2.csv").exists():
            sections += _table2(base / "table2.csv", f"Table 2, {label}")
    for folder, label in families[1:]:
        base = out / folder
        if (base / "table3.csv").exists():
            sections += _sumo_rates(base / "table3.csv", f"Table 3, {label}", PAPER_TABLE3,
                                    "initial", "winner")
        if (base / "table4.csv").exists():
            sections += _sumo_table4(base / "table4.csv", f"Table 4 (the window after "
                                     f"learning; initial: the initial drivers driving on), "
                                     f"{label}")
    if (out / "table3.csv").exists():
        sections += _rates(out / "table3.csv", "Table 3", PAPER_TABLE3)
    if (out / "table4.csv").exists():
        sections += _rates(out / "table4.csv", "Table 4 (the span after learning; initial: the "
                           "initial drivers driving on)", PAPER_TABLE4)
    return ["## The paper's tables beside these", "", *sections] if sections else []


def _sumo_rates(path: Path, title: str, paper, before: str, after: str) -> list[str]:
    table = pd.read_csv(path)
    lines = [f"### {title}: collisions per second, paper (its count) / here (per "
             "learner, 90% interval over situations); SSM conflicts per learner-hour (each "
             "arm's SUMO in a fresh process)", "",
             "| strategy | initial | after | conflicts, initial -> after |", "|---|---|---|---|"]

    def cell(row, span: str, value: float) -> str:
        return (f"{_pair(value, row[f'{span}_collisions_per_s'])} "
                f"({row[f'{span}_low']:g}–{row[f'{span}_high']:g})")

    for i, row in table.iterrows():
        lines.append(f"| {int(row['strategy'])} | {cell(row, before, paper[i][0])} | "
                     f"{cell(row, after, paper[i][1])} | {row[f'{before}_conflicts_per_h']:g} -> "
                     f"{row[f'{after}_conflicts_per_h']:g} |")
    return [*lines, ""]


def _sumo_table4(path: Path, title: str) -> list[str]:
    """A SUMO family's Table 4: both arms over the window after learning and their paired
    difference with its 90% interval."""
    table = pd.read_csv(path)
    name = "population_minus_initial_after"
    lines = [f"### {title}: collisions per second, paper (its count) / here (per learner); "
             "the paired difference with its 90% interval over situations; SSM conflicts per "
             "learner-hour (each arm's SUMO in a fresh process)", "",
             "| strategy | initial | after | after − initial | conflicts, initial -> after |",
             "|---|---|---|---|---|"]
    for i, row in table.iterrows():
        lines.append(f"| {int(row['strategy'])} | "
                     f"{_pair(PAPER_TABLE4[i][0], row['initial_after_collisions_per_s'])} | "
                     f"{_pair(PAPER_TABLE4[i][1], row['population_collisions_per_s'])} | "
                     f"{row[name]:+g} ({row[f'{name}_low']:+g} to {row[f'{name}_high']:+g}) | "
                     f"{row['initial_after_conflicts_per_h']:g} -> "
                     f"{row['population_conflicts_per_h']:g} |")
    return [*lines, ""]
