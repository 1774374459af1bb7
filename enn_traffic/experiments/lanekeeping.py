"""Paper §5.6: lane keeping from camera lane markings, with highway-env — learning on one
road or on roads drawn per situation, and keeping the lane on roads never seen in training."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd

from enn_traffic.config import Scenario
from enn_traffic.config.shipped import shipped_scenario
from enn_traffic.core import keys
from enn_traffic.core.io import write_csv
from enn_traffic.experiments.choosing import candidates
from enn_traffic.experiments.common import run_or_reuse, save_controller
from enn_traffic.experiments.study import Runs, Study
from enn_traffic.learning.evaluators import ProcessEvaluator
from enn_traffic.report.plots import draw_paths, learning_curves, save_figure
from enn_traffic.runs.controller import Controller
from enn_traffic.sim.lane_keeping.road import SPEED, CameraLaneKeepingEnv
from enn_traffic.sim.lane_keeping.world import LaneKeepingWorld
from enn_traffic.sim.world import CAPPED, make_world
from enn_traffic.sumo.fresh import fresh_shares


@dataclass(frozen=True)
class LaneKeepingRuns(Runs):
    """The runs, and on how many roads drawn from the validation key a drawn-road run's
    controller is chosen (:func:`chosen`)."""

    validation_roads: int = 20


RUNS = LaneKeepingRuns(seeds=(1, 2, 3), quick={"seeds": (1,), "validation_roads": 5,
                                               "ga": {"population_size": 12, "generations": 5,
                                                      "elite_count": 2}})
DRAWN_STEPS = 400
# Trained on highway-env's road alone, or on roads drawn per situation.
TRAININGS = ["lane_keeping", "lane_keeping_mixed"]
# Measured on fixed roads: highway-env's training road and roads neither training drove (the
# mixed training draws sizes from ranges that hold most of these, never these roads
# themselves). Each design read some of them before the present one; ``FRESH`` were read by
# the present design alone (``fresh`` in lane_keeping.csv). The first seven were read by
# the first design (best.npz of runs drawing periods of 60-160 m) ...
READ_BEFORE = {
    "training sine (5 m, 100 m)": {},
    "gentle sine (3 m, 150 m)": {"amplitude": 3.0, "period": 150.0},
    "tight sine (6 m, 70 m)": {"amplitude": 6.0, "period": 70.0},
    "tight sine, mirrored": {"amplitude": 6.0, "period": 70.0, "mirrored": True},
    "circle, radius 60 m": {"road": "circle", "radius": 60.0},
    "circle, radius 40 m": {"road": "circle", "radius": 40.0},
    "circle, radius 40 m, anticlockwise": {"road": "circle", "radius": 40.0, "mirrored": True},
    # ... these five by the second (the controller chosen on validation roads) ...
    "sine (4 m, 80 m)": {"amplitude": 4.0, "period": 80.0},
    "sine (6.5 m, 90 m), mirrored": {"amplitude": 6.5, "period": 90.0, "mirrored": True},
    "sine (2.5 m, 65 m), mirrored": {"amplitude": 2.5, "period": 65.0, "mirrored": True},
    "circle, radius 45 m, anticlockwise": {"road": "circle", "radius": 45.0, "mirrored": True},
    "circle, radius 75 m": {"road": "circle", "radius": 75.0},
    # ... these five by the third (periods drawn from 50-110 m, 15 generations) ...
    "sine (7 m, 75 m)": {"amplitude": 7.0, "period": 75.0},
    "sine (5 m, 60 m), mirrored": {"amplitude": 5.0, "period": 60.0, "mirrored": True},
    "sine (3.5 m, 120 m)": {"amplitude": 3.5, "period": 120.0},
    "circle, radius 35 m": {"road": "circle", "radius": 35.0},
    "circle, radius 50 m, anticlockwise": {"road": "circle", "radius": 50.0, "mirrored": True},
}
# ... and these by the present one (30 generations, chosen from the whole final population)
# alone.
FRESH = {
    "sine (6 m, 65 m)": {"amplitude": 6.0, "period": 65.0},
    "sine (4.5 m, 55 m), mirrored": {"amplitude": 4.5, "period": 55.0, "mirrored": True},
    "sine (3 m, 52 m), mirrored": {"amplitude": 3.0, "period": 52.0, "mirrored": True},
    "sine (5.5 m, 85 m)": {"amplitude": 5.5, "period": 85.0},
    "circle, radius 38 m, anticlockwise": {"road": "circle", "radius": 38.0, "mirrored": True},
    "circle, radius 55 m": {"road": "circle", "radius": 55.0},
}
ROADS = READ_BEFORE | FRESH
# The camera's noise is drawn from a test key no earlier design read (the sealed test range).
TEST_KEY = keys.LANE_KEEPING_TEST.start
NOISES = [0.0, 0.1]  # the camera's noise when measured (m)
# The keys of a road, which ROADS change from the one-road training's (highway-env's) road.
ROAD_KEYS = ["road", "amplitude", "period", "radius", "mirrored", "draw"]


def lane_keeping(study: Study) -> list[str]:
    """Evolve on highway-env's road and on drawn roads (process pool), then drive the best
    controller of each run on every road of ``ROADS``, with and without camera noise:
    ``lane_keeping.csv``, ``lane_keeping.png``, ``lane_keeping_paths.png``."""
    out, settings = study.out, study.settings(RUNS)
    seeds = settings.seeds
    runs, best = {}, {}
    for name in TRAININGS:
        base = shipped_scenario(name)
        for seed in seeds:
            sc = base.with_overrides(seed=seed, ga=dict(settings.ga))
            run_dir = out / "runs" / name / f"seed{seed}"
            evaluator = ProcessEvaluator(sc)
            try:
                runs[name, seed] = run_or_reuse(sc, run_dir, study.progress,
                                                evaluator=evaluator)
            finally:
                evaluator.close()
            best[name, seed] = chosen(sc, run_dir, settings.validation_roads)
            save_controller(out, f"lane_keeping/{name}_seed{seed}", sc, best[name, seed],
                            runs[name, seed]["best_fitness"].max())
    cap = shipped_scenario(TRAININGS[0]).episode.max_steps
    learning_curves({f"{name.removeprefix('lane_keeping').strip('_') or 'one road'}, seed {s}": t
                     for (name, s), t in runs.items()}, out / "lane_keeping.png",
                    title="Lane keeping (highway-env): best steps in lane per generation "
                    "(mixed: fresh roads every generation)", hline=cap)
    rows, paths = [], {}
    # the paths drawn: the last training's first seed, with the last noise
    drawn = (TRAININGS[-1], NOISES[-1], seeds[0])
    # the test lives in fresh processes, a share each (the same as one after another: each
    # life resets its road and draws its noise from the test key)
    measured = iter(fresh_shares(road_lives, [(name, road, noise, best[name, seed],
                                               (name, noise, seed) == drawn)
                                              for name in TRAININGS for road in ROADS
                                              for noise in NOISES for seed in seeds]))
    for name in TRAININGS:
        for road in ROADS:
            for noise in NOISES:
                for seed in seeds:
                    steps, outcome, offset, path = next(measured)
                    if path is not None:
                        paths[road] = path
                    rows.append({"trained_on": name, "road": road, "fresh": road in FRESH,
                                 "noise_m": noise,
                                 "seed": seed, "steps_in_lane": steps,
                                 "kept_whole_episode": outcome == CAPPED,
                                 "mean_abs_offset_m": round(offset, 3),
                                 "generations_to_cap": _first_cap(runs[name, seed], cap),
                                 # the run's generations over every call that made it, so
                                 # that a reused or resumed run does not read 0
                                 "training_wall_s": round(float(
                                     runs[name, seed]["elapsed_s"].iloc[-1]), 1)})
    table = pd.DataFrame(rows)
    write_csv(out / "lane_keeping.csv", table)
    _draw_roads(paths, out / "lane_keeping_paths.png", TRAININGS[-1], NOISES[-1])
    return lane_keeping_lines(study)


def lane_keeping_lines(study: Study) -> list[str]:
    """The summary's lines, from the ``lane_keeping.csv`` the study wrote."""
    table = pd.read_csv(study.out / "lane_keeping.csv")
    seeds = table["seed"].nunique()
    lines = []
    for (name, noise), group in table.groupby(["trained_on", "noise_m"], sort=False):
        kept = group.groupby("road", sort=False)["kept_whole_episode"].sum()
        lines.append(
            f"lane_keeping: trained on {name}, camera noise {noise:g} m: runs keeping the lane "
            "for the whole capped episode: "
            + ", ".join(f"{road}: {kept[road]}/{seeds}" for road in kept.index))
    return lines


def road_world(training: str, road: str, noise: float) -> LaneKeepingWorld:
    """The world a ``training``'s controller is measured in: one life on the fixed road
    ``road`` of ``ROADS`` (highway-env's road with the changes it names), its camera's noise
    ``noise`` m."""
    one_road = shipped_scenario(TRAININGS[0]).lane_keeping.model_dump(include=set(ROAD_KEYS))
    return make_world(shipped_scenario(training).with_overrides(
        lane_keeping={**one_road, **ROADS[road], "noise_m": noise, "episodes": 1}))


def road_lives(lives: list[tuple[str, str, float, np.ndarray, bool]]) -> list[tuple]:
    """Each life (training, road of ``ROADS``, camera noise, chromosome, whether its path is
    drawn) on the test key: steps kept in the lane, outcome, mean |lateral offset|, and the
    road's walls and the vehicle's positions (n, 3) where drawn (else None)."""
    worlds: dict[tuple, LaneKeepingWorld] = {}
    results = []
    for name, road, noise, chromosome, drawn in lives:
        if (name, road, noise) not in worlds:
            worlds[name, road, noise] = road_world(name, road, noise)
        world = worlds[name, road, noise]
        path = (world.track.walls, world.trace(chromosome, TEST_KEY)[0][:, 0]) if drawn else None
        results.append((*world.offsets(chromosome, TEST_KEY)[0], path))
    return results


def chosen(scenario: Scenario, run_dir: Path, roads: int = RUNS.validation_roads
           ) -> np.ndarray:
    """A run's controller. On one road, its ``best.npz``: the road it will drive is the one it
    trained on. On drawn roads, the candidate (every generation's best and the whole final
    population) that keeps the lane longest, on average, on ``roads`` roads drawn
    from the validation key; the earliest of equals. (``best.npz`` is the first chromosome to
    reach the highest fitness on one generation's few roads, and the final elites are the
    fittest on the last generation's: measured on validation roads, both weak choices;
    docs/history.md, "Lane keeping".)"""
    if scenario.lane_keeping.draw is None:
        return Controller.load(run_dir / "best.npz").chromosome
    pool = candidates(run_dir, whole_population=True)
    validation = scenario.with_overrides(lane_keeping={"episodes": roads})
    evaluator = ProcessEvaluator(validation)
    try:
        fitness = evaluator.evaluate(pool, keys.CHOOSING.start).fitness
    finally:
        evaluator.close()
    return pool[int(np.argmax(fitness))]


def _first_cap(table: pd.DataFrame, cap: int) -> float:
    hits = table.loc[table["best_fitness"] >= cap, "generation"]
    return float(hits.iloc[0]) if len(hits) else float("nan")


def _draw_roads(paths: dict, path: Path, name: str, noise: float) -> None:
    columns = (len(paths) + 1) // 2
    figure, axes = plt.subplots(2, columns, figsize=(3.2 * columns, 6.4))
    for ax in axes.flat[len(paths):]:
        ax.set_axis_off()
    for ax, (road, (walls, poses)) in zip(axes.flat, paths.items(), strict=False):
        shown = poses[:DRAWN_STEPS]
        draw_paths(ax, walls, [shown], colors=["C3"], width=1.5)
        ax.set_xlim(shown[:, 0].min() - 10, shown[:, 0].max() + 10)
        ax.set_ylim(shown[:, 1].min() - 10, shown[:, 1].max() + 10)
        ax.set_aspect("auto")
        ax.set_title(road, fontsize=9)
        ax.set_xticks([])
        ax.set_yticks([])
    figure.suptitle(f"Lane keeping: a {name} controller (red) between the lane markings, "
                    f"camera noise {noise:g} m, first {DRAWN_STEPS} steps")
    figure.tight_layout()
    save_figure(figure, path)
    plt.close(figure)



def road_facts(folder: Path) -> dict:
    """Facts (docs/_generate/README.md): the fixed roads ``lane_keeping.csv`` measured, each
    as ``ROADS`` makes it of highway-env's road (kind, amplitude and period of a sine, radius
    of a circle, mirrored or not), with its peak curvature in 1/m (a sine ``A sin(2 pi x /
    P)``: ``A (2 pi / P)^2``, at its crests; a circle: ``1 / radius``) and the radius of its
    sharpest bend; and a capped episode in steps and metres (highway-env's speed and policy
    frequency)."""
    table = pd.read_csv(folder / "lane_keeping.csv")
    base = shipped_scenario(TRAININGS[0])
    roads = {}
    for name in table["road"].unique():
        road = base.lane_keeping.model_copy(update=ROADS[name])
        curvature = (road.amplitude * (2 * np.pi / road.period) ** 2 if road.road == "sine"
                     else 1 / road.radius)
        roads[name] = {"kind": road.road, "mirrored": road.mirrored,
                       **({"amplitude": road.amplitude, "period": road.period}
                          if road.road == "sine" else {"radius": road.radius}),
                       "peak_curvature": round(float(curvature), 6),
                       "sharpest_radius": round(float(1 / curvature), 3)}
    steps = base.episode.max_steps
    frequency = CameraLaneKeepingEnv.default_config()["policy_frequency"]
    return {"roads": roads, "episode_steps": steps,
            "episode_m": round(steps * SPEED / frequency, 3)}
