"""Paper §5.1–5.2: learning navigation (Fig. 7, 8), sensor resolution (Fig. 9), and
generalisation of the wide-track controller to unseen tracks."""

from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd

from enn_traffic.controller import Controller
from enn_traffic.evaluation import controller_trace, evaluate_controller
from enn_traffic.experiments.common import first_generation, run_or_reuse, scenario
from enn_traffic.io import write_csv
from enn_traffic.report.plots import learning_curves, save_figure

# Best fitness at which the vehicle has reached the far dead end of the narrow track
# (location B, ≈1.3 km of corridor; reference-implementation.md §8.19).
REACHED_B = 1200
SEEDS = [1, 2, 3, 4, 5]
QUICK = {"population_size": 60, "generations": 20}
UNSEEN_TRACKS = ["unseen_narrow", "unseen_loop", "unseen_zigzag", "unseen_grid"]


def _settings(quick: bool, **ga) -> dict:
    return {**ga, **(QUICK if quick else {})}


def _seed_runs(name: str, out: Path, seeds, quick: bool, progress: bool, label: str = "",
               **overrides):
    """One run per seed under ``out/runs/LABEL/seedN`` (LABEL defaults to the scenario name);
    runs of equal settings share a folder, so fig7 and fig9's 19-beam runs are done once."""
    base = scenario(name)
    runs = {}
    for seed in seeds:
        sc = base.with_overrides(seed=seed, ga=_settings(quick), **overrides)
        runs[seed] = run_or_reuse(sc, out / "runs" / (label or name) / f"seed{seed}", progress)
    return runs


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
    cap = scenario("navigation_wide").episode.max_steps
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


def fig9(out: Path, quick: bool = False, progress: bool = True) -> list[str]:
    """Sensor resolution: 1, 3, 5, 10, 19 beams over 180° on the narrow track."""
    seeds = SEEDS[:1] if quick else SEEDS
    beam_counts = [1, 3, 5, 10, 19]
    rows, curves = [], {}
    for beams in beam_counts:
        label = "navigation_narrow" if beams == 19 else f"navigation_narrow_{beams}beams"
        runs = _seed_runs("navigation_narrow", out, seeds, quick, progress, label=label,
                          sensor={"beams": beams})
        for seed, table in runs.items():
            rows.append({"beams": beams, "seed": seed,
                         "generations_to_accepted": first_generation(table, REACHED_B),
                         "max_best_fitness": table["best_fitness"].max()})
        stacked = np.stack([t["best_fitness"].to_numpy() for t in runs.values()])
        curves[f"{beams} beam{'s' if beams > 1 else ''}"] = pd.DataFrame({
            "generation": next(iter(runs.values()))["generation"],
            "best_fitness": np.median(stacked, axis=0)})
    per_run = pd.DataFrame(rows)
    summary = per_run.groupby("beams").agg(
        runs=("seed", "size"),
        runs_accepted=("generations_to_accepted", lambda s: int(s.notna().sum())),
        median_generations_to_accepted=("generations_to_accepted", "median"),
        mean_max_best_fitness=("max_best_fitness", "mean"),
    ).reset_index()
    write_csv(out / "fig9_runs.csv", per_run)
    write_csv(out / "fig9.csv", summary)
    learning_curves(curves, out / "fig9.png", hline=REACHED_B, log=True,
                    title="Fig. 9: sensor resolution (median best over seeds)")
    accepted = summary.dropna(subset=["median_generations_to_accepted"])
    fastest = (int(accepted.loc[accepted["median_generations_to_accepted"].idxmin(), "beams"])
               if len(accepted) else None)
    return [
        "fig9: runs reaching accepted fitness per beam count: "
        + ", ".join(f"{int(r.beams)}: {r.runs_accepted}/{r.runs}" for r in summary.itertuples())
        + f"; fastest (median generations): {fastest} beams (paper: 1 beam fails, 5 fastest)",
    ]


def generalization(out: Path, quick: bool = False, progress: bool = True) -> list[str]:
    """The best wide-track controller on tracks it never saw."""
    runs_dir = out / "runs" / "navigation_wide"
    if not any(runs_dir.glob("seed*/best.npz")):
        fig8(out, quick, progress)
    candidates = [Controller.load(p) for p in sorted(runs_dir.glob("seed*/best.npz"))]
    best = max(candidates, key=lambda c: c.fitness)
    best.save(out / "generalization_controller.npz")
    rows, figure_paths = [], []
    for name in ["navigation_wide", *UNSEEN_TRACKS]:
        sc = scenario(name)
        table = evaluate_controller(best, sc)
        rows.append(table.iloc[0].to_dict())
        world, poses, _ = controller_trace(best, sc, max_steps=3000)
        figure_paths.append((world, poses, name))
    table = pd.DataFrame(rows)
    write_csv(out / "generalization.csv", table)
    figure, axes = plt.subplots(1, len(figure_paths), figsize=(4 * len(figure_paths), 4.2))
    for ax, (world, poses, name) in zip(axes, figure_paths, strict=True):
        for x1, y1, x2, y2 in world.track.walls:
            ax.plot([x1, x2], [y1, y2], color="black", lw=0.6)
        ax.plot(poses[:, 0], poses[:, 1], lw=0.8, color="C0")
        ax.plot(*world.start[:2], "o", color="C2")
        ax.set_aspect("equal")
        ax.set_title(name, fontsize=9)
        ax.set_xticks([])
        ax.set_yticks([])
    figure.suptitle("Best wide-track controller on unseen tracks (first 3000 steps)")
    figure.tight_layout()
    save_figure(figure, out / "generalization.png")
    capped = table[table["capped"]]["scenario"].tolist()
    return [
        "generalization: lifetimes (steps) "
        + ", ".join(f"{r['scenario']}: {int(r['lifetime_steps'])} ({r['outcome']})" for r in rows)
        + f"; reached the cap on {len(capped)} of {len(rows)} tracks",
    ]
