"""Paper §5.6: lane keeping from camera lane markings, with highway-env — learning on the
training road and keeping the lane on roads never seen in training."""

from __future__ import annotations

import time
from pathlib import Path

import matplotlib.pyplot as plt
import pandas as pd

from enn_traffic.controller import Controller
from enn_traffic.evolution.backends import ProcessEvaluator
from enn_traffic.experiments.common import run_or_reuse
from enn_traffic.io import write_csv
from enn_traffic.report.plots import draw_paths, learning_curves, save_figure
from enn_traffic.shipped import shipped_scenario
from enn_traffic.sim.world import CAPPED
from enn_traffic.worlds import make_world

SEEDS = [1, 2, 3]
DRAWN_STEPS = 400
QUICK = {"population_size": 20, "generations": 6, "elite_count": 2}
# The training road (highway-env's: amplitude 5 m, period 100 m) and roads never trained on.
ROADS = {
    "training sine (5 m, 100 m)": {},
    "gentle sine (3 m, 150 m)": {"amplitude": 3.0, "period": 150.0},
    "tight sine (6 m, 70 m)": {"amplitude": 6.0, "period": 70.0},
    "circle, radius 60 m": {"road": "circle", "radius": 60.0},
    "circle, radius 40 m": {"road": "circle", "radius": 40.0},
}


def lane_keeping(out: Path, quick: bool = False, progress: bool = True) -> list[str]:
    """Evolve on the training road (process pool), then drive the best controller of each
    run on every road: ``lane_keeping.csv``, ``lane_keeping.png``, ``lane_keeping_paths.png``."""
    base = shipped_scenario("lane_keeping")
    seeds = SEEDS[:1] if quick else SEEDS
    runs, best, wall = {}, {}, {}
    for seed in seeds:
        sc = base.with_overrides(seed=seed, ga=QUICK if quick else {})
        run_dir = out / "runs" / "lane_keeping" / f"seed{seed}"
        evaluator = ProcessEvaluator(sc)
        try:
            started = time.perf_counter()
            runs[seed] = run_or_reuse(sc, run_dir, progress, evaluator=evaluator)
            wall[seed] = time.perf_counter() - started
        finally:
            evaluator.close()
        best[seed] = Controller.load(run_dir / "best.npz").chromosome
    learning_curves({f"seed {s}": t for s, t in runs.items()}, out / "lane_keeping.png",
                    title="Lane keeping (highway-env): best steps in lane per generation",
                    hline=base.episode.max_steps)
    rows, paths = [], {}
    for road, changes in ROADS.items():
        world = make_world(base.with_overrides(lane_keeping=changes))
        for seed in seeds:
            steps, outcome, offset = world.offsets(best[seed])[0]
            rows.append({"road": road, "seed": seed, "steps_in_lane": steps,
                         "kept_whole_episode": outcome == CAPPED,
                         "mean_abs_offset_m": round(offset, 3)})
        paths[road] = (world.track.walls, world.trace(best[seeds[0]])[0][:, 0])
    table = pd.DataFrame(rows)
    table["generations_to_cap"] = table["seed"].map(
        {s: _first_cap(t, base.episode.max_steps) for s, t in runs.items()})
    table["training_wall_s"] = table["seed"].map({s: round(w, 1) for s, w in wall.items()})
    write_csv(out / "lane_keeping.csv", table)
    _draw(paths, out / "lane_keeping_paths.png")
    kept = table.groupby("road", sort=False)["kept_whole_episode"].sum()
    offsets = table.groupby("road", sort=False)["mean_abs_offset_m"].mean()
    return ["lane_keeping: runs keeping the lane for the whole capped episode: "
            + ", ".join(f"{road}: {kept[road]}/{len(seeds)} ({offsets[road]:.2f} m mean offset)"
                        for road in ROADS)]


def _first_cap(table: pd.DataFrame, cap: int) -> float:
    hits = table.loc[table["best_fitness"] >= cap, "generation"]
    return float(hits.iloc[0]) if len(hits) else float("nan")


def _draw(paths: dict, path: Path) -> None:
    figure, axes = plt.subplots(1, len(paths), figsize=(4 * len(paths), 4))
    for ax, (road, (walls, poses)) in zip(axes, paths.items(), strict=True):
        shown = poses[:DRAWN_STEPS]
        draw_paths(ax, walls, [shown], colors=["C3"], width=1.5)
        ax.set_xlim(shown[:, 0].min() - 10, shown[:, 0].max() + 10)
        ax.set_ylim(shown[:, 1].min() - 10, shown[:, 1].max() + 10)
        ax.set_aspect("auto")
        ax.set_title(road, fontsize=9)
        ax.set_xticks([])
        ax.set_yticks([])
    figure.suptitle(f"Lane keeping: the evolved controller (red) between the lane markings, "
                    f"first {DRAWN_STEPS} steps")
    figure.tight_layout()
    save_figure(figure, path)
    plt.close(figure)

