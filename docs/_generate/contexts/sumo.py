"""docs/sumo.md: "Every car learning in your city", from the committed crowd run
(``enn-traffic crowd``'s folder, ``results/crowd_brunswick``), and "Safety figures", from the
committed closed-loop evaluation ``results/safety/city_closed_loop.csv``."""

from __future__ import annotations

import tomllib
from pathlib import Path

import numpy as np
import pandas as pd


def safety(table: pd.DataFrame) -> dict:
    """What the two safety measures saw of the collisions with vehicles in an ``evaluate``
    table of closed-loop lives."""
    hits = table[(table["outcome"] == "collision") & (table["hit"] == "vehicle")]
    return {"lives": len(table), "controllers": sorted(table["controller"].unique()),
            "scenarios": sorted(table["scenario"].unique()),
            "situations": int(table["situation"].nunique()), "hits": len(hits),
            "finite_2d": int(np.isfinite(hits["min_ttc_2d_s"]).sum()),
            "ssm_inf": int(np.isinf(hits["min_ttc_s"]).sum()),
            "walls_touching": int(((table["outcome"] == "collision") & (table["hit"] == "wall")
                                   & (table["min_ttc_2d_s"] == 0)).sum())}


def context(root: Path) -> dict:
    safe = safety(pd.read_csv(root / "results" / "safety" / "city_closed_loop.csv"))
    folder = root / "results" / "crowd_brunswick"
    scenario = tomllib.loads((folder / "crowd.toml").read_text())
    generations = pd.read_csv(folder / "individual" / "generations.csv")
    best = generations["best_fitness"].idxmax()
    bred = pd.read_csv(folder / "table4_learners.csv")["generations_bred"]
    return {"safety": safe, "crowd": {
        "learners": scenario["traffic"]["learners"], "settings": scenario["crowd"],
        "population": scenario["ga"]["population_size"],
        "situations": len(pd.read_csv(folder / "crowd_situations.csv")),
        "generations": len(generations),
        "best_fitness": generations["best_fitness"].max(),
        "best_generation": int(generations["generation"][best]),
        "table3": pd.read_csv(folder / "table3.csv").iloc[0],
        "table4": pd.read_csv(folder / "table4.csv").iloc[0],
        "has_2d": "population_conflicts_2d_per_h" in pd.read_csv(folder / "table4.csv"),
        "bred": {"median": bred.median(), "min": bred.min(), "max": bred.max()}}}
