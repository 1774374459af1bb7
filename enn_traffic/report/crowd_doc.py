"""docs/sumo.md's section "Every car learning in your city" written from a crowd run's committed
files (``enn-traffic crowd``'s folder, ``results/crowd_brunswick``), never typed."""

from __future__ import annotations

import sys
import tomllib
from pathlib import Path

import pandas as pd

from enn_traffic.report import generated


def _difference(row: pd.Series, name: str) -> str:
    """A paired difference with its interval: ``name``, ``name_low``, ``name_high``."""
    return f"{row[name]:+.4f} ({row[name + '_low']:+.4f} to {row[name + '_high']:+.4f})"


def _side(row: pd.Series, name: str) -> str:
    """Where a paired difference's interval lies: below 0, above 0, or across it."""
    if row[name + "_high"] < 0:
        return "below 0"
    return "above 0" if row[name + "_low"] > 0 else "across 0"


def crowd_tables(folder: Path) -> str:
    """Tables 3–4 of the run in ``folder``: its settings, each arm's rate, the paired
    differences with their 90% intervals, and what the learners bred."""
    scenario = tomllib.loads((folder / "crowd.toml").read_text())
    crowd, learners = scenario["crowd"], scenario["traffic"]["learners"]
    table3 = pd.read_csv(folder / "table3.csv").iloc[0]
    table4 = pd.read_csv(folder / "table4.csv").iloc[0]
    situations = pd.read_csv(folder / "crowd_situations.csv")
    bred = pd.read_csv(folder / "table4_learners.csv")["generations_bred"]
    generations = pd.read_csv(folder / "individual" / "generations.csv")
    lines = [
        f"{learners} learners at once in one SUMO, {len(situations)} test situations; the "
        f"winner from {len(generations)} generations of the scenario's GA (population "
        f"{scenario['ga']['population_size']}; its best training fitness, "
        f"{generations['best_fitness'].max():.0f} steps, in generation "
        f"{generations['generation'][generations['best_fitness'].idxmax()]}); "
        f"{crowd['learning_s']:g} s of SUMO "
        f"time learning together, rates over windows of {crowd['window_s']:g} s. Collisions "
        "per learner-second (responsible collisions), SSM conflicts (TTC < 1.5 s) per "
        "learner-hour; differences paired by situation, with their 90% bootstrap interval:",
        "",
        "| | arm | collisions per learner-second | SSM conflicts per learner-hour |",
        "|---|---|---:|---:|",
        f"| Table 3, first window | initial drivers (random networks) | "
        f"{table3.initial_collisions_per_s:.4f} | {table3.initial_conflicts_per_h:.1f} |",
        f"| | the winner for all | {table3.winner_collisions_per_s:.4f} | "
        f"{table3.winner_conflicts_per_h:.1f} |",
        f"| | winner − initial | {_difference(table3, 'winner_minus_initial')} | |",
        f"| Table 4, window after learning | initial drivers | "
        f"{table4.initial_after_collisions_per_s:.4f} | "
        f"{table4.initial_after_conflicts_per_h:.1f} |",
        f"| | every vehicle after learning together | "
        f"{table4.population_collisions_per_s:.4f} | {table4.population_conflicts_per_h:.1f} |",
        f"| | the winner driving on | {table4.winner_after_collisions_per_s:.4f} | "
        f"{table4.winner_after_conflicts_per_h:.1f} |",
        f"| | after learning − initial drivers | "
        f"{_difference(table4, 'population_minus_initial_after')} | |",
        f"| | after learning − winner driving on | "
        f"{_difference(table4, 'population_minus_winner_after')} | |",
        "",
        f"Each learner bred {bred.median():g} generations (median; {bred.min()}–{bred.max()}) "
        "while learning. The paper's pattern: Table 3, the winner for all below the initial "
        f"drivers — here the paired interval lies {_side(table3, 'winner_minus_initial')}; "
        "Table 4, learning together below both — against the initial drivers it lies "
        f"{_side(table4, 'population_minus_initial_after')}, against the winner driving on "
        f"{_side(table4, 'population_minus_winner_after')}.",
    ]
    return "\n".join(lines)


SECTIONS: generated.Sections = {"crowd_brunswick": crowd_tables}

if __name__ == "__main__":
    root = Path(sys.argv[1]) if len(sys.argv) > 1 else Path(".")
    generated.rewrite(root / "docs" / "sumo.md", root / "results" / "crowd_brunswick", SECTIONS)
