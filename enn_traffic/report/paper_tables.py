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
        if (base / "table4.csv").exists() and (base / "table3.csv").exists():
            sections += _sumo_table4(base, f"Table 4 (initial: the initial drivers' first "
                                     f"window, the paper's baseline, as in Table 3; after: the "
                                     f"window after learning), {label}")
    if (out / "table3.csv").exists():
        sections += _rates(out / "table3.csv", "Table 3", PAPER_TABLE3)
    if (out / "table4.csv").exists() and (out / "table3.csv").exists():
        sections += _table4(out, "Table 4 (initial: the initial drivers' first span, the "
                            "paper's baseline, as in Table 3; after: the span after learning)")
    return ["## The paper's tables beside these", "", *sections] if sections else []


def _conflicts(row: pd.Series, before: str, after: str) -> str:
    """An arm pair's conflicts per learner-hour, SSM's and the 2-D ones (docs/sumo.md,
    "Safety figures")."""
    return " · ".join(f"{name} {row[f'{before}_{column}_per_h']:g} -> "
                      f"{row[f'{after}_{column}_per_h']:g}"
                      for name, column in (("SSM", "conflicts"), ("2-D", "conflicts_2d")))


def _sumo_rates(path: Path, title: str, paper, before: str, after: str) -> list[str]:
    table = pd.read_csv(path)
    lines = [f"### {title}: collisions per second, paper (its count) / here (per "
             "learner, 90% interval over situations); conflicts per learner-hour, SUMO's SSM "
             "and the 2-D time to collision below 1.5 s (each arm's SUMO in a fresh process)",
             "",
             "| strategy | initial | after | conflicts, initial -> after |", "|---|---|---|---|"]

    def cell(row, span: str, value: float) -> str:
        return (f"{_pair(value, row[f'{span}_collisions_per_s'])} "
                f"({row[f'{span}_low']:g}–{row[f'{span}_high']:g})")

    for i, row in table.iterrows():
        lines.append(f"| {int(row['strategy'])} | {cell(row, before, paper[i][0])} | "
                     f"{cell(row, after, paper[i][1])} | {_conflicts(row, before, after)} |")
    return [*lines, ""]


def _table4(folder: Path, title: str) -> list[str]:
    """The arena's Table 4: the paper's initial column beside the initial drivers' first
    span (``table3.csv``), its after column beside the learners after learning, and the
    initial drivers over that same later span (``table4.csv``)."""
    initial = pd.read_csv(folder / "table3.csv")["initial_collisions_per_s"]
    table = pd.read_csv(folder / "table4.csv")
    lines = [f"### {title}: collisions per second, paper (its count) / here (per vehicle)", "",
             "| strategy | initial | after | here: the initial drivers driving on |",
             "|---|---|---|---|"]
    for i, row in table.iterrows():
        lines.append(f"| {int(row['strategy'])} | {_pair(PAPER_TABLE4[i][0], initial[i])} | "
                     f"{_pair(PAPER_TABLE4[i][1], row['population_collisions_per_s'])} | "
                     f"{row['initial_after_collisions_per_s']:g} |")
    return [*lines, ""]


def _sumo_table4(folder: Path, title: str) -> list[str]:
    """A SUMO family's Table 4: the initial drivers' first window (``table3.csv``) and the
    learners over the window after learning, and the learners' paired difference from the
    initial drivers driving on over that window, with its 90% interval."""
    initial = pd.read_csv(folder / "table3.csv")["initial_collisions_per_s"]
    table = pd.read_csv(folder / "table4.csv")
    name = "population_minus_initial_after"
    lines = [f"### {title}: collisions per second, paper (its count) / here (per learner); "
             "the paired difference from the initial drivers driving on, with its 90% "
             "interval over situations; conflicts per learner-hour, SUMO's SSM and the 2-D "
             "time to collision below 1.5 s (each arm's SUMO in a fresh process)", "",
             "| strategy | initial | after | after − the initial drivers driving on | "
             "conflicts, driving on -> after |", "|---|---|---|---|---|"]
    for i, row in table.iterrows():
        lines.append(f"| {int(row['strategy'])} | "
                     f"{_pair(PAPER_TABLE4[i][0], initial[i])} | "
                     f"{_pair(PAPER_TABLE4[i][1], row['population_collisions_per_s'])} | "
                     f"{row[name]:+g} ({row[f'{name}_low']:+g} to {row[f'{name}_high']:+g}) | "
                     f"{_conflicts(row, 'initial_after', 'population')} |")
    return [*lines, ""]
