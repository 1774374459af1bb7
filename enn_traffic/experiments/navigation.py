"""Paper §5.1–5.2: learning navigation (Fig. 7, 8), sensor resolution (Fig. 9), and
generalisation: controllers trained on one track or on several, on tracks they never saw
(§5.1)."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd
from tqdm import tqdm

from enn_traffic.config.shipped import shipped_scenario
from enn_traffic.core.io import write_csv
from enn_traffic.core.progress import terminal
from enn_traffic.experiments.common import first_generation, save_controller
from enn_traffic.experiments.study import Runs, Study, seed_runs
from enn_traffic.report.plots import draw_paths, heat_map, learning_curves, save_figure
from enn_traffic.runs.controller import Controller
from enn_traffic.runs.evaluate import controller_trace
from enn_traffic.sim.world import CAPPED, OUTCOMES

# Best fitness at which the vehicle has reached the far dead end of the narrow track
# (location B, ≈1.3 km of corridor; docs/design.md, "The authors' code" 1).
REACHED_B = 1200
# Five GA seeds per training; --quick: two, and a small GA.
RUNS = Runs(seeds=(1, 2, 3, 4, 5), quick={"seeds": (1, 2), "ga": {"population_size": 60,
                                                                   "generations": 20}})
SENSOR_RUNS = replace(RUNS, quick={**RUNS.quick, "seeds": (1,)})  # Fig. 9: six sensors
# Generalisation: the scenarios controllers train on, and the tracks they are
# measured on, narrowest first. The validation tracks (unseen_*, 12-30 m) were read once as a
# test, then decided the design of training across tracks; the test tracks (test_*, 12-30 m)
# were built then and are read by the final configuration alone. Each has the step cap
# STEP_CAP.
TRAINED = ["navigation_narrow", "navigation_wide", "navigation_mixed"]
VALIDATION_TRACKS = ["unseen_narrow", "unseen_zigzag14", "unseen_loop16", "unseen_junctions20",
                     "unseen_wide", "unseen_loop", "unseen_zigzag", "unseen_grid"]
TEST_TRACKS = ["test_junctions12", "test_bends13", "test_square16", "test_snake20",
               "test_junctions24", "test_loop26", "test_zigzag30"]
UNSEEN_TRACKS = VALIDATION_TRACKS + TEST_TRACKS
TRACK_SET = {**dict.fromkeys(VALIDATION_TRACKS, "validation"),
             **dict.fromkeys(TEST_TRACKS, "test")}
STEP_CAP = 20_000
PATH_STEPS = 3000


def fig7(study: Study) -> list[str]:
    """Narrow track, 5 seeds: does the best vehicle reach location B within 50 generations?"""
    out = study.out
    runs = seed_runs(study, "navigation_narrow", RUNS)
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
    return fig7_lines(study)


def fig7_lines(study: Study) -> list[str]:
    """The summary's Fig. 7 line, from the ``fig7.csv`` the study wrote."""
    summary = pd.read_csv(study.out / "fig7.csv")
    reached = int(summary["reached_B_generation"].notna().sum())
    return [
        f"fig7: best vehicle reached location B (≥{REACHED_B} steps) in {reached} of "
        f"{len(summary)} seeds; generations to reach it: "
        f"{_generations(summary['reached_B_generation'])}; max best fitness "
        f"{summary['max_best_fitness'].max():.0f} steps (paper: <50 generations, stalls at B)",
    ]


def _generations(column: pd.Series) -> str:
    """Each seed's generation, in seed order: ``18, 17, never``."""
    return ", ".join("never" if pd.isna(g) else f"{g:.0f}" for g in column)


def fig8(study: Study) -> list[str]:
    """Wide track, 5 seeds: back and forth without collision up to the step cap."""
    out = study.out
    runs = seed_runs(study, "navigation_wide", RUNS)
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
    return fig8_lines(study)


def fig8_lines(study: Study) -> list[str]:
    """The summary's Fig. 8 line, from the ``fig8.csv`` the study wrote."""
    summary = pd.read_csv(study.out / "fig8.csv")
    cap = shipped_scenario("navigation_wide").episode.max_steps
    capped = int(summary["capped_generation"].notna().sum())
    return [
        f"fig8: best vehicle drove to the {cap}-step cap in {capped} of {len(summary)} seeds, at "
        f"generations {_generations(summary['capped_generation'])} (paper: 'very high fitness')",
    ]


# Fig. 9 sensors: (beams, span in degrees). The paper spreads every sensor over 180°; the
# authors' code used 45°, 90°, 135° for three beams, a 90° span, run here as an extra variant.
SENSORS = [(1, 180.0), (3, 180.0), (5, 180.0), (10, 180.0), (19, 180.0), (3, 90.0)]


def fig9(study: Study) -> list[str]:
    """Sensor resolution: 1, 3, 5, 10, 19 beams over 180° on the narrow track."""
    out, settings = study.out, study.settings(SENSOR_RUNS)
    seeds = settings.seeds
    base = shipped_scenario("navigation_narrow")
    jobs = {}  # every sensor's runs at once: side by side on Ray
    for beams, span in SENSORS:
        label = "navigation_narrow" if beams == 19 else f"navigation_narrow_{beams}beams"
        label += "" if span == 180.0 else f"_{span:g}deg"
        for seed in seeds:
            jobs[beams, span, seed] = (
                base.with_overrides(seed=seed, ga=dict(settings.ga),
                                    sensor={"beams": beams, "span_deg": span}),
                out / "runs" / label / f"seed{seed}")
    tables = study.run_all(jobs)
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
    return fig9_lines(study)


def fig9_lines(study: Study) -> list[str]:
    """The summary's Fig. 9 line, from the ``fig9.csv`` the study wrote."""
    summary = pd.read_csv(study.out / "fig9.csv")
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


def generalization(study: Study) -> list[str]:
    """Controllers trained on one track (narrow, wide) or on five at once (mixed), 5 seeds
    each, on tracks they never trained on: the validation tracks (``VALIDATION_TRACKS``) and
    the test tracks (``TEST_TRACKS``), 12–30 m; steps to the cap and the share of the track
    covered. A controller drives every track by its training's spin rule
    (:meth:`Controller.fit`). Pairs whose track a controller trained on are marked ``seen``."""
    out, seeds = study.out, study.settings(RUNS).seeds
    controllers = {}
    for name in TRAINED:
        seed_runs(study, name, RUNS)
        for seed in seeds:
            path = out / "runs" / name / f"seed{seed}" / "best.npz"
            controllers[name, seed] = Controller.load(path)
            save_controller(out, f"generalization/{name}_seed{seed}", shipped_scenario(name),
                            controllers[name, seed].chromosome, controllers[name, seed].fitness)
    unseen = {track: shipped_scenario(track) for track in UNSEEN_TRACKS}
    trainings = {name: shipped_scenario(name) for name in TRAINED}
    # Each controller on every unseen track, and on its own training tracks at its training
    # cap (how much of them it drives).
    pairs = [(key, track, scenario) for key in controllers for track, scenario in unseen.items()]
    pairs += [(key, track.net.name.removesuffix(".net.xml"), trainings[key[0]].on_track(i))
              for key in controllers for i, track in enumerate(trainings[key[0]].tracks)]
    rows, traces = [], {}
    for (name, seed), track, scenario in tqdm(
            pairs, desc="generalization", unit="pair", disable=not study.progress, leave=False,
            file=terminal()):
        world, poses, outcome = controller_trace(controllers[name, seed], scenario)
        trained_on = {t.net for t in trainings[name].tracks}
        rows.append({
            "trained_on": name, "seed": seed, "track": track, "tracks": TRACK_SET.get(track,
                                                                                   "training"),
            "seen": scenario.track.net in trained_on, "cap": scenario.episode.max_steps,
            "steps": len(poses) - 1, "outcome": OUTCOMES[outcome],
            "capped": outcome == CAPPED,
            "coverage": round(world.track.coverage(poses[:, 0, :2]), 4),
        })  # fmt: skip
        if seed == seeds[0] and track in TEST_TRACKS:
            traces[name, track] = (world, poses[:PATH_STEPS + 1, 0])
    table = pd.DataFrame(rows)
    write_csv(out / "generalization.csv", table)
    matrix = unseen_matrix(table, TRAINED, UNSEEN_TRACKS)
    write_csv(out / "generalization_matrix.csv", matrix.reset_index())
    heat_map(100 * matrix, out / "generalization.png", label="% of seeds at the cap",
             title=f"Unseen tracks: controllers at the {STEP_CAP}-step cap, % of {len(seeds)} "
             "seeds (blank: trained on it); validation tracks, then test tracks")
    _path_figure(traces, out / "generalization_paths.png", seeds[0])
    return generalization_lines(study)


def generalization_lines(study: Study) -> list[str]:
    """The summary's generalisation lines, from the ``generalization.csv`` the study wrote."""
    table = pd.read_csv(study.out / "generalization.csv")
    unseen_rows = table[~table["seen"] & (table["tracks"] != "training")]
    shares = unseen_rows.groupby(["tracks", "trained_on"], sort=False)["capped"].agg(
        ["sum", "size"])
    own = table[table["tracks"] == "training"]
    covered = own.groupby("trained_on", sort=False)[["capped", "coverage"]].mean()
    return [
        f"generalization: (controller, {kind} track) pairs at the step cap, by training: "
        + ", ".join(f"{name}: {int(r['sum'])}/{int(r['size'])} ({100 * r['sum'] / r['size']:.0f}%)"
                    for (group, name), r in shares.iterrows() if group == kind)
        + (" (the target for navigation_mixed: 90%)" if kind == "test" else
           " (the tracks the design was chosen on)")
        for kind in ("test", "validation")
    ] + [
        "generalization: on their own training tracks, at the cap / share of the track covered: "
        + ", ".join(f"{name}: {100 * r['capped']:.0f}% / {100 * r['coverage']:.0f}%"
                    for name, r in covered.iterrows()),
    ]


def unseen_matrix(table: pd.DataFrame, trained: list[str], tracks: list[str]) -> pd.DataFrame:
    """Share of each training's seeds at the step cap on each track (rows ``trained``, columns
    ``tracks``), from generalization.csv's rows; NaN where the training drove that track."""
    unseen = table[~table["seen"].astype(bool)]
    shares = unseen.groupby(["trained_on", "track"])["capped"].mean().unstack("track")
    return shares.reindex(index=trained, columns=tracks).rename_axis(index="trained_on",
                                                                     columns=None)


def _path_figure(traces: dict, path: Path, seed: int) -> None:
    """Each training's first seed on every test track, its first ``PATH_STEPS`` steps."""
    figure, axes = plt.subplots(len(TRAINED), len(TEST_TRACKS),
                                figsize=(2.4 * len(TEST_TRACKS), 2.6 * len(TRAINED)))
    for row, name in zip(axes, TRAINED, strict=True):
        for ax, track in zip(row, TEST_TRACKS, strict=True):
            world, xy = traces[name, track]
            draw_paths(ax, world.track.walls, [xy], colors=["C0"], start=tuple(xy[0]),
                       width=0.6)
            ax.set_xticks([])
            ax.set_yticks([])
            if name == TRAINED[0]:
                ax.set_title(track.removeprefix("test_"), fontsize=9)
        row[0].set_ylabel(name.removeprefix("navigation_"), fontsize=9)
    figure.suptitle(f"Seed {seed} of each training on the test tracks (first {PATH_STEPS} "
                    "steps)")
    figure.tight_layout()
    save_figure(figure, path)
