"""Run saved controllers on scenarios and report lifetimes (``enn-traffic evaluate``).

One controller on one scenario gives a row per traffic situation; several controllers and
scenarios give one tidy table of every pair's situations and the controller x scenario matrix
of mean fitness (Table 1 for any set of scenarios), spread over a process pool or Ray.
"""

from __future__ import annotations

import multiprocessing
from collections.abc import Sequence
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np
import pandas as pd
from tqdm import tqdm

from enn_traffic.config import Scenario, learner_start_time
from enn_traffic.core import keys
from enn_traffic.core.errors import InputError
from enn_traffic.core.geometry import body_corners
from enn_traffic.core.io import write_csv
from enn_traffic.core.progress import slow_step, terminal
from enn_traffic.learning.evaluators import connect_ray
from enn_traffic.roads.network import lanes_at
from enn_traffic.runs.controller import Controller
from enn_traffic.sim.world import (
    CAPPED,
    HIT_WALL,
    MET_NEAR_MAX,
    MET_NEAR_STEPS,
    MET_START,
    OUTCOMES,
    SituationResults,
    World,
    make_world,
)

# Evaluation episodes draw the test traffic (:mod:`enn_traffic.core.keys`), so a controller is never
# deployed on the traffic it was trained on, whether its training drew new traffic every
# generation or kept one set, nor on the traffic any choice was made on.
EVALUATION_KEY = keys.EVALUATION.start
MAX_LABELLED = 9  # vehicles drawn with a legend entry each


def evaluate_controller(controller: Controller, scenario: Scenario, episodes: int = 1
                        ) -> pd.DataFrame:
    """One row per traffic strategy and situation: lifetime in steps and seconds, distance, how
    it ended and, for a collision, what it ran into (a wall, or a vehicle: its SUMO id and
    type, or an arena vehicle's index and strategy), and the collisions the controller
    suffered without causing them. Among SUMO's traffic, also where and when the life ended
    (:func:`_ends`: the network's x, y, lane and edge, and SUMO's clock).

    Episodes draw their traffic from the test keys (:data:`EVALUATION_KEY`), never from
    training's; scenarios without traffic are deterministic, so their episodes repeat one
    another. A scenario of several tracks gives each track's rows in turn.
    """
    if isinstance(scenario.track, list):
        return pd.concat([evaluate_controller(controller, scenario.on_track(index), episodes)
                          for index in range(len(scenario.track))], ignore_index=True)
    world = make_world(evaluation_scenario(controller, scenario, episodes))
    vehicle = scenario.vehicle
    lives = len(world.situation_labels())
    waits = (" (SUMO starts and warms up; on a first run numba compiles the kernels)"
             if scenario.traffic.is_sumo else "")
    with slow_step(f"{lives} {'life' if lives == 1 else 'lives'} on {scenario.name}'s test "
                   f"traffic{waits}"):
        results = world.evaluate(controller.chromosome[None, :], EVALUATION_KEY)
    steps, outcome = results.steps[0], results.outcome[0]
    fitness = SituationResults.lifetime_fitness(steps, outcome)
    traffic = results.traffic[0]
    ends = _ends(results, scenario)
    alike = (world.first_alike(EVALUATION_KEY) if hasattr(world, "first_alike")
             else list(range(episodes)))  # SUMO's shared warm-ups can start two alike
    rows = []
    for column, strategy in enumerate(world.situation_labels()):
        rows.append({
            "scenario": scenario.name,
            "track": world.track.name,
            "strategy": strategy,
            "situation": column % episodes,
            "same_start_as": alike[column % episodes],
            "steps": int(steps[column]),
            "lifetime_s": steps[column] * vehicle.dt,
            "distance_m": steps[column] * vehicle.speed * vehicle.dt,
            "fitness": fitness[column],
            "outcome": OUTCOMES[int(outcome[column])],
            **_hit(results, column, strategy),
            **ends[column],
            "capped": bool(outcome[column] == CAPPED),
            "suffered": int(results.suffered[0, column]),
            "traffic_at_start": int(traffic[column, MET_START]),
            "traffic_near_mean": traffic[column, MET_NEAR_STEPS] / (steps[column] + 1),
            "traffic_near_max": int(traffic[column, MET_NEAR_MAX]),
            **_safety(results.safety, column, steps[column] * vehicle.dt),
        })  # fmt: skip
    return pd.DataFrame(rows)


def _hit(results: SituationResults, column: int, strategy: str) -> dict[str, str]:
    """What the first world's life in ``column`` ran into: ``hit`` (wall, vehicle or nothing),
    and the vehicle's id and type (a SUMO vehicle's own; an arena vehicle's index and
    strategy)."""
    hit = int(results.hit[0, column])
    if hit == HIT_WALL:
        return {"hit": "wall", "hit_vehicle": "", "hit_type": ""}
    if hit < 0:
        return {"hit": "", "hit_vehicle": "", "hit_type": ""}
    named = None if results.hit_vehicle is None else results.hit_vehicle[0, column]
    vehicle, kind = named if named is not None else (str(hit), strategy)
    return {"hit": "vehicle", "hit_vehicle": vehicle, "hit_type": kind}


def _ends(results: SituationResults, scenario: Scenario) -> list[dict]:
    """Where and when each life of the first world ended, among SUMO's traffic (else no
    columns): the learner's position in the network's coordinates (``end_x_m``,
    ``end_y_m``), the lane and edge of the learner's surface nearest it (blank off the road),
    and the SUMO time (``end_sumo_time_s``) as SUMO's outputs label that step, to find a
    collision in SUMO's own outputs (``traffic.outputs``) or in sumo-gui: SUMO labels a step by
    the time it begins at, where its clock (``simulation.getTime``) reads the time it ends at,
    so the learner's last pose, which its last step put into SUMO, is labelled its start plus
    one step fewer than it moved (its start, when it ended before moving)."""
    if results.end_pose is None or not scenario.traffic.is_sumo:
        return [{}] * results.steps.shape[1]
    xy = results.end_pose[0, :, :2]
    lanes = lanes_at(scenario.track.net, xy, scenario.track.surface)
    times = (learner_start_time(scenario)
             + np.maximum(results.steps[0] - 1, 0) * scenario.vehicle.dt)
    return [{"end_x_m": round(float(x), 2), "end_y_m": round(float(y), 2),
             "end_edge": lane.rpartition("_")[0], "end_lane": lane,
             "end_sumo_time_s": round(float(time), 3)}
            for (x, y), lane, time in zip(xy.tolist(), lanes, times.tolist(), strict=True)]


def _safety(safety, column: int, lifetime_s: float) -> dict[str, float]:
    """The safety columns of a closed-loop row (none in replay): SSM's lowest TTC, its
    conflicts by measure and all three per hour of the learner's life; the two-dimensional
    time to collision over the footprints (:mod:`enn_traffic.sim.safety`), its least and the
    steps below SSM's TTC threshold (docs/sumo.md, "Safety figures")."""
    if safety is None:
        return {}
    min_ttc, ttc, drac, pet, min_ttc_2d, ttc_2d_steps = safety[0, column]
    hours = max(lifetime_s, 1e-9) / 3600.0
    return {"min_ttc_s": min_ttc, "ttc_conflicts": int(ttc), "drac_conflicts": int(drac),
            "pet_conflicts": int(pet), "ttc_conflicts_per_h": ttc / hours,
            "drac_conflicts_per_h": drac / hours, "pet_conflicts_per_h": pet / hours,
            "min_ttc_2d_s": min_ttc_2d, "ttc_2d_steps": int(ttc_2d_steps)}


def _evaluate_pair(label: str, controller: Controller, scenario: Scenario, episodes: int
                   ) -> pd.DataFrame:
    table = evaluate_controller(controller, scenario, episodes)
    table.insert(0, "controller", label)
    return table


def _one_thread() -> None:
    import numba

    numba.set_num_threads(1)


def evaluate_batch(controllers: dict[str, Controller], scenarios: Sequence[Scenario],
                   episodes: int = 1, executor: str = "local", address: str | None = None,
                   progress: bool = True) -> pd.DataFrame:
    """Every controller on every scenario (each fitted to it first, so a misfit is an error
    before anything runs): one row per (controller, scenario, situation). ``executor``:
    ``local`` (one pair after another, numba threads over the cores), ``process`` (pairs over a
    process pool, one core each) or ``ray`` (pairs as Ray tasks of one core)."""
    pairs = [(label, controller, scenario) for label, controller in controllers.items()
             for scenario in scenarios]
    for _, controller, scenario in pairs:
        controller.fit(scenario, scenario.source)
    bar = tqdm(file=terminal(),
               total=len(pairs), desc="evaluate", unit="pair", disable=not progress,
               leave=False)
    tables = []
    try:
        if executor == "local":
            for pair in pairs:
                tables.append(_evaluate_pair(*pair, episodes))
                bar.update(1)
        elif executor == "process":
            context = multiprocessing.get_context("spawn")  # numba threads and libsumo
            with ProcessPoolExecutor(mp_context=context, initializer=_one_thread) as pool:
                futures = [pool.submit(_evaluate_pair, *pair, episodes) for pair in pairs]
                for future in futures:
                    tables.append(future.result())
                    bar.update(1)
        elif executor == "ray":
            ray = connect_ray(address)
            task = ray.remote(num_cpus=1)(_evaluate_pair)
            futures = [task.remote(*pair, episodes) for pair in pairs]
            for future in futures:
                tables.append(ray.get(future))
                bar.update(1)
        else:
            raise InputError(f"unknown executor {executor!r}; use local, process or ray",
                             key="--executor")
    finally:
        bar.close()
    return pd.concat(tables, ignore_index=True)


def fitness_matrix(table: pd.DataFrame) -> pd.DataFrame:
    """Mean fitness of each controller (rows, in table order) on each scenario (columns), over
    its distinct starting states: situations that start alike (``same_start_as``) count once,
    by their mean."""
    starts = table.groupby(["controller", "scenario", "strategy", "same_start_as"],
                           sort=False)["fitness"].mean().reset_index()
    matrix = starts.pivot_table(index="controller", columns="scenario", values="fitness",
                                aggfunc="mean", sort=False)
    matrix.columns.name = None
    return matrix


def distinct_starts(table: pd.DataFrame) -> tuple[int, int]:
    """(distinct starting states, situations) of each (controller, scenario) pair: the fewest
    distinct over the pairs, and the situations of that pair."""
    pairs = table.groupby(["controller", "scenario"], sort=False)
    counts = pairs.apply(lambda rows: (rows[["strategy", "same_start_as"]].drop_duplicates()
                                       .shape[0], len(rows)), include_groups=False)
    return min(counts, key=lambda c: c[0] / c[1])


def matrix_files(out: Path) -> tuple[Path, Path]:
    """Where :func:`write_batch` puts the matrix of ``out``: ``<out>_matrix.csv`` and
    ``<out>_matrix.png`` (heat map)."""
    stem = out.with_name(out.stem + "_matrix")
    return stem.with_suffix(".csv"), stem.with_suffix(".png")


def write_batch(table: pd.DataFrame, out: Path) -> list[Path]:
    """``out`` (the tidy table) and the matrix files (:func:`matrix_files`)."""
    from enn_traffic.report.plots import heat_map  # matplotlib only where it draws

    matrix = fitness_matrix(table)
    table_file, picture = matrix_files(out)
    write_csv(out, table)
    write_csv(table_file, matrix.reset_index())
    distinct, situations = distinct_starts(table)
    over = (f"{situations} situation(s)" if distinct == situations
            else f"{distinct} distinct starting states of {situations} situations")
    heat_map(matrix, picture, f"mean fitness over {over}", "mean fitness [steps]")
    return [out, table_file, picture]


def evaluation_scenario(controller: Controller, scenario: Scenario, episodes: int) -> Scenario:
    """``scenario`` fitted to the controller, with ``episodes`` traffic situations (a lane
    keeping scenario's episodes are ``[lane_keeping] episodes``: it has no ``[traffic]``)."""
    section = "lane_keeping" if scenario.lane_keeping is not None else "traffic"
    return controller.fit(scenario).with_overrides(**{section: {"episodes": episodes}})


def controller_trace(
    controller: Controller, scenario: Scenario, max_steps: int | None = None, situation: int = 0
) -> tuple[World, np.ndarray, int]:
    """The world, every vehicle's poses (n, V, 3) in one life, and the learner's outcome."""
    world = make_world(evaluation_scenario(controller, scenario, situation + 1))
    poses, outcome = world.trace(
        controller.chromosome, EVALUATION_KEY, situation, max_steps=max_steps
    )
    return world, poses, outcome


def render(
    controller: Controller, scenario: Scenario, out: str | Path, max_steps: int | None = None,
    progress: bool = True,
) -> dict:
    """Draw the controller's path on the track (PNG) or animate it (GIF, its frames with a
    progress bar)."""
    from enn_traffic.report.animate import animate_run
    from enn_traffic.report.plots import trajectories

    out = Path(out)
    if scenario.traffic.is_sumo and not isinstance(scenario.track, list) \
            and out.suffix.lower() != ".gif":
        return _render_among_traffic(controller, scenario, out, max_steps)
    world, poses, outcome = controller_trace(controller, scenario, max_steps)
    steps = len(poses) - 1
    title = f"{scenario.name}: {steps} steps, {OUTCOMES[outcome]}"
    if out.suffix.lower() == ".gif":
        animate_run(world, poses, out, title, progress=progress,
                    sumo_start=learner_start_time(scenario) if scenario.traffic.is_sumo
                    else None)
    else:
        paths = [poses[:, v] for v in range(poses.shape[1])]
        labels, colors = ["learner"] + [f"vehicle {v}" for v in range(1, len(paths))], None
        if len(paths) > MAX_LABELLED:  # SUMO traffic: the learner in red among grey traffic
            labels = ["learner", "traffic"] + [None] * (len(paths) - 2)
            colors = ["C3"] + ["0.6"] * (len(paths) - 1)
        trajectories(world.track.walls, paths, out, title=title, start=tuple(poses[0, 0]),
                     labels=labels if len(paths) > 1 else None, colors=colors)
    return {"steps": steps, "outcome": OUTCOMES[outcome], "file": str(out)}


def _render_among_traffic(controller: Controller, scenario: Scenario, out: Path,
                          max_steps: int | None) -> dict:
    """A life among SUMO's traffic, cropped to the learner's path, with what it ran into."""
    from enn_traffic.report.plots import learner_among_traffic

    world = make_world(evaluation_scenario(controller, scenario, 1))
    life = world.trace_life(controller.chromosome, EVALUATION_KEY, 0, max_steps)
    seed = world.seeds(EVALUATION_KEY)[0]
    steps, outcome = len(life.poses) - 1, OUTCOMES[life.outcome]
    end = f"end: {outcome} at step {steps}"
    if life.hit == HIT_WALL:
        end = f"end: collision with a wall at step {steps}"
    elif life.hit_vehicle is not None:
        end = f"end: collision with {life.hit_vehicle[0]} ({life.hit_vehicle[1]}) at step {steps}"
    vehicle, body = world.scenario.vehicle, np.empty((4, 2))
    body_corners(*life.poses[-1, 0], vehicle.length, vehicle.width, body)
    learner_among_traffic(world.track.walls, world.exits, life.poses, out,
                          f"{scenario.name}: {steps} steps, {outcome}\n"
                          f"held-out situation 0 (SUMO seed {seed})", end, life.hit_body,
                          learner_body=body)
    return {"steps": steps, "outcome": outcome, "file": str(out)}

