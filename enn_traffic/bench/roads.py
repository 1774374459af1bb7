"""Preparing a large network: its walls and wall grid, first time and from the cache."""

from __future__ import annotations

import tempfile
from pathlib import Path

import numpy as np
import pandas as pd

from enn_traffic.bench.measure import environment, measured, random_city
from enn_traffic.roads import load_track
from enn_traffic.sim.sensors import WallGrid


def network(quick: bool = False) -> pd.DataFrame:
    """Preparing a large network: its walls and the wall grid, built the first time and
    loaded from the cache after, with the peak memory of each (a smaller network with
    ``quick``)."""
    reach = 29.5  # the default sensor's: 25 m range, a 4.3 m body, 1 m spare
    rows = []
    with tempfile.TemporaryDirectory(prefix="enn-bench-network-") as folder, \
            environment(ENN_TRAFFIC_CACHE=str(Path(folder) / "cache")):  # cold, then warm
        for iterations in (150,) if quick else (100, 1500):
            net = random_city(iterations)
            walls_s, _, track = measured(lambda n=net: load_track(n, exits=True), False)
            grid_s, grid_mb, grid = measured(lambda t=track: WallGrid.cached(t.walls, reach))
            again, again_mb, _ = measured(lambda n=net: WallGrid.cached(
                load_track(n, exits=True).walls, reach))
            workload = (f"network: random city, {len(track.walls):,} walls, "
                        f"{grid.cells_x * grid.cells_y:,} cells")
            for implementation, seconds, memory in (
                    ("grid: walls binned into cells", grid_s, grid_mb),
                    ("walls and grid, first time", walls_s + grid_s, np.nan),
                    ("walls and grid, from the cache", again, again_mb)):
                rows.append({"workload": workload, "implementation": implementation,
                             "threads": 1, "seconds": seconds, "peak_memory_mb": memory,
                             "speedup_vs_reference": np.nan})
    return pd.DataFrame(rows)
