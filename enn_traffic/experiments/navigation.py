"""Paper §5.1–5.2: learning navigation (Fig. 7, 8), sensor resolution (Fig. 9), and
generalisation of the wide-track controller to unseen tracks."""

from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd

from enn_traffic.controller import Controller
from enn_traffic.deploy import controller_trace, evaluate_controller
from enn_traffic.experiments.common import first_generation, run_all, seed_runs
from enn_traffic.io import write_csv
from enn_traffic.report.plots import draw_paths, learning_curves, save_figure
from enn_traffic.shipped import shipped_scenario

# Best fitness at which the vehicle has reached the far dead end of the narrow track
# (location B, ≈1.3 km of corridor; docs/design.md, "The authors' code" 1).
REACHED_B = 1200
SEEDS = [1, 2, 3, 4, 5]
QUICK = {"population_size": 60, "generations": 20}
UNSEEN_TRACKS = ["unseen_narrow", "unseen_loop", "unseen_zigzag", "unseen_grid"]


def _seed_runs(name: str, out: Path, seeds, quick: bool, progress: bool):
    return seed_runs(name, out, seeds, QUICK if quick else {}, progress)


def fig7(out: Path, quick: bool = False, progress: bool = True) -> list[str]:
    """Narrow track, 5 seeds: does the best vehicle reach location B within 50 generations?"""
    seeds = SEEDS[:2] if quick else SEEDS
    runs = _seed_runs("navigation_narrow", out, seeds, quick, progress)
    rows = []
    for seed, table in runs.items():
        rows.append({
            "seed": seed,
            "generations": len(table),
            "passed_A_generation": first_generation(table, 100),
            "reached_B_generation": first_generation(table, REACHED_B),
            "max_best_fitness": table["best_fitness"].max(),
            "final_best_fitness": table["best_fitness"].iloc[-1],
            "generations_at_or_above_B": int((table["best_fitness"] >= REACHED_B).sum()),
        })  # fmt: skip
    summary = pd.DataFrame(rows)
    write_csv(out / "fig7.csv", summary)
    learning_curves({f"seed {s}": t for s, t in runs.items()}, out / "fig7.png",
                    title="Fig. 7: narrow track (12 m)", hline=REACHED_B)
    reached = int(summary["reached_B_generation"].notna().sum())
    return [
        f"fig7: best vehicle reached location B (≥{REACHED_B} steps) in {reached} of "
        f"{len(seeds)} seeds; generations to reach it: "
        f"{summary['reached_B_generation'].tolist()}; max best fitness "
        f"{summary['max_best_fitness'].max():.0f} steps (paper: <50 generations, stalls at B)",
    ]


def fig8(out: Path, quick: bool = False, progress: bool = True) -> list[str]:
    """Wide track, 5 seeds: back and forth without collision up to the step cap."""
    seeds = SEEDS[:2] if quick else SEEDS
    runs = _seed_runs("navigation_wide", out, seeds, quick, progress)
    cap = shipped_scenario("navigation_wide").episode.max_steps
    rows = [{
        "seed": seed,
        "generations": len(table),
        "reached_B_generation": first_generation(table, 2 * REACHED_B),
        "capped_generation": first_generation(table, cap),
        "max_best_fitness": table["best_fitness"].max(),
    } for seed, table in runs.items()]  # fmt: skip
    summary = pd.DataFrame(rows)
    write_csv(out / "fig8.csv", summary)
    learning_curves({f"seed {s}": t for s, t in runs.items()}, out / "fig8.png",
                    title="Fig. 8: wide track (30 m)", hline=cap, log=True)
    capped = int(summary["capped_generation"].notna().sum())
    return [
        f"fig8: best vehicle drove to the {cap}-step cap in {capped} of {len(seeds)} seeds, at "
        f"generations {summary['capped_generation'].tolist()} (paper: 'very high fitness')",
    ]


# Fig. 9 sensors: (beams, span in degrees). The paper spreads every sensor over 180°; the
# authors' code used 45°, 90°, 135° for three beams, a 90° span, run here as an extra variant.
SENSORS = [(1, 180.0), (3, 180.0), (5, 180.0), (10, 180.0), (19, 180.0), (3, 90.0)]


def fig9(out: Path, quick: bool = False, progress: bool = True) -> list[str]:
    """Sensor resolution: 1, 3, 5, 10, 19 beams over 180° on the narrow track."""
    seeds = SEEDS[:1] if quick else SEEDS
    base = shipped_scenario("navigation_narrow")
    jobs = {}  # every sensor's runs at once: side by side on Ray
    for beams, span in SENSORS:
        label = "navigation_narrow" if beams == 19 else f"navigation_narrow_{beams}beams"
        label += "" if span == 180.0 else f"_{span:g}deg"
        for seed in seeds:
            jobs[beams, span, seed] = (
                base.with_overrides(seed=seed, ga=QUICK if quick else {},
                                    sensor={"beams": beams, "span_deg": span}),
                out / "runs" / label / f"seed{seed}")
    tables = run_all(jobs, progress)
    rows, curves = [], {}
    for beams, span in SENSORS:
        runs = {seed: tables[beams, span, seed] for seed in seeds}
        for seed, table in runs.items():
            rows.append({"beams": beams, "span_deg": span, "seed": seed,
                         "generations_to_accepted": first_generation(table, REACHED_B),
                         "max_best_fitness": table["best_fitness"].max()})
        stacked = np.stack([t["best_fitness"].to_numpy() for t in runs.values()])
        name = f"{beams} beam{'s' if beams > 1 else ''}" + ("" if span == 180 else f", {span:g}°")
        curves[name] = pd.DataFrame({
            "generation": next(iter(runs.values()))["generation"],
            "best_fitness": np.median(stacked, axis=0)})
    per_run = pd.DataFrame(rows)
    summary = per_run.groupby(["beams", "span_deg"], sort=False).agg(
        runs=("seed", "size"),
        runs_accepted=("generations_to_accepted", lambda s: int(s.notna().sum())),
        median_generations_to_accepted=("generations_to_accepted", "median"),
        mean_max_best_fitness=("max_best_fitness", "mean"),
    ).reset_index()
    write_csv(out / "fig9_runs.csv", per_run)
    write_csv(out / "fig9.csv", summary)
    learning_curves(curves, out / "fig9.png", hline=REACHED_B, log=True,
                    title="Fig. 9: sensor resolution (median best over seeds)")
    over_180 = summary[summary["span_deg"] == 180.0]
    accepted = over_180.dropna(subset=["median_generations_to_accepted"])
    fastest = (int(accepted.loc[accepted["median_generations_to_accepted"].idxmin(), "beams"])
               if len(accepted) else None)
    return [
        f"fig9: runs reaching {REACHED_B} steps within the generations, per sensor: "
        + ", ".join(f"{int(r.beams)} beams/{r.span_deg:g}°: {r.runs_accepted}/{r.runs} "
                    f"(median {r.median_generations_to_accepted:g} generations)"
                    for r in summary.itertuples())
        + f"; fastest over 180°: {fastest} beams (paper: 1 beam fails, 5 fastest)",
    ]


def generalization(out: Path, quick: bool = False, progress: bool = True) -> list[str]:
    """The best controller of every wide-track run on tracks it never saw."""
    runs_dir = out / "runs" / "navigation_wide"
    if not any(runs_dir.glob("seed*/best.npz")):
        fig8(out, quick, progress)
    controllers = {
        path.parent.name: Controller.load(path) for path in sorted(runs_dir.glob("seed*/best.npz"))
    }
    tracks = ["navigation_wide", *UNSEEN_TRACKS]
    rows = []
    for run, controller in controllers.items():
        for name in tracks:
            row = evaluate_controller(controller, shipped_scenario(name)).iloc[0].to_dict()
            rows.append({"controller": run, "trained_fitness": controller.fitness, **row})
    table = pd.DataFrame(rows)
    write_csv(out / "generalization.csv", table)
    # The picture: the first run whose controller reached the cap on its training track.
    capped_runs = table[(table["scenario"] == "navigation_wide") & table["capped"]]["controller"]
    shown = capped_runs.iloc[0] if len(capped_runs) else next(iter(controllers))
    figure, axes = plt.subplots(1, len(tracks), figsize=(4 * len(tracks), 4.2))
    for ax, name in zip(axes, tracks, strict=True):
        world, poses, _ = controller_trace(controllers[shown], shipped_scenario(name),
                                           max_steps=3000)
        draw_paths(ax, world.track.walls, [poses[:, 0]], colors=["C0"], start=world.start,
                   width=0.8)
        ax.set_title(name, fontsize=9)
        ax.set_xticks([])
        ax.set_yticks([])
    figure.suptitle(f"Best wide-track controller ({shown}) on unseen tracks (first 3000 steps)")
    figure.tight_layout()
    save_figure(figure, out / "generalization.png")
    per_track = table.groupby("scenario", sort=False)["capped"].agg(["sum", "size"])
    return [
        "generalization: controllers reaching the step cap, per track: "
        + ", ".join(f"{name}: {int(r['sum'])}/{int(r['size'])}"
                    for name, r in per_track.iterrows()),
    ]
