"""docs/sumo.md: "Every car learning in your city", from the committed crowd run
(``enn-traffic crowd``'s folder, ``results/crowd_brunswick``)."""

from __future__ import annotations

import tomllib
from pathlib import Path

import pandas as pd


def context(root: Path) -> dict:
    folder = root / "results" / "crowd_brunswick"
    scenario = tomllib.loads((folder / "crowd.toml").read_text())
    generations = pd.read_csv(folder / "individual" / "generations.csv")
    best = generations["best_fitness"].idxmax()
    bred = pd.read_csv(folder / "table4_learners.csv")["generations_bred"]
    return {"crowd": {
        "learners": scenario["traffic"]["learners"], "settings": scenario["crowd"],
        "population": scenario["ga"]["population_size"],
        "situations": len(pd.read_csv(folder / "crowd_situations.csv")),
        "generations": len(generations),
        "best_fitness": generations["best_fitness"].max(),
        "best_generation": int(generations["generation"][best]),
        "table3": pd.read_csv(folder / "table3.csv").iloc[0],
        "table4": pd.read_csv(folder / "table4.csv").iloc[0],
        "bred": {"median": bred.median(), "min": bred.min(), "max": bred.max()}}}
