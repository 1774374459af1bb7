"""docs/sumo.md: "Every car learning in your city", from the committed crowd run
(``enn-traffic crowd``'s folder, ``results/crowd_brunswick``), and "Safety figures", from the
committed closed-loop evaluation ``results/safety/city_closed_loop.csv``."""

from __future__ import annotations

import tomllib
from pathlib import Path

import numpy as np
import pandas as pd

from enn_traffic.config.base import MAX_LEARNERS


def _safety_counts(table: pd.DataFrame) -> dict:
    """What the two safety measures saw in ``table``'s lives."""
    collided = table["outcome"] == "collision"
    hits = table[collided & (table["hit"] == "vehicle")]
    walls = table[collided & (table["hit"] == "wall") & (table["min_ttc_2d_s"] == 0)]
    struck = table[table["suffered"] > 0]
    untouched = table[~collided & (table["suffered"] == 0)]
    return {"lives": len(table), "hits": len(hits),
            "finite_2d": int(np.isfinite(hits["min_ttc_2d_s"]).sum()),
            "ssm_inf": int(np.isinf(hits["min_ttc_s"]).sum()),
            "walls_touching": len(walls), "walls_struck": int((walls["suffered"] > 0).sum()),
            "struck": len(struck),
            "struck_zero": int(((struck["min_ttc_s"] == 0)
                                & (struck["min_ttc_2d_s"] == 0)).sum()),
            "ssm_zero_untouched": int(((untouched["min_ttc_s"] == 0)
                                       & np.isinf(untouched["min_ttc_2d_s"])).sum())}


def safety(table: pd.DataFrame) -> dict:
    """What the two safety measures saw in an ``evaluate`` table of closed-loop lives: over
    all of them, and over those from distinct starting states (``same_start_as``: a life that
    starts as an earlier one is a near copy of it)."""
    distinct = table[table["same_start_as"] == table["situation"]]
    return {"lives": len(table), "controllers": sorted(table["controller"].unique()),
            "scenarios": sorted(table["scenario"].unique()),
            "situations": int(table["situation"].nunique()),
            "all": _safety_counts(table), "distinct": _safety_counts(distinct)}


def context(root: Path) -> dict:
    safe = safety(pd.read_csv(root / "results" / "safety" / "city_closed_loop.csv"))
    folder = root / "results" / "crowd_brunswick"
    scenario = tomllib.loads((folder / "crowd.toml").read_text(encoding="utf-8"))
    generations = pd.read_csv(folder / "individual" / "generations.csv")
    best = generations["best_fitness"].idxmax()
    bred = pd.read_csv(folder / "table4_learners.csv")["generations_bred"]
    return {"safety": safe, "max_learners": MAX_LEARNERS, "crowd": {
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
