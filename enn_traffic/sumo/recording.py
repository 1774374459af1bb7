"""SUMO run once without the learner and kept step by step (replay mode,
:mod:`enn_traffic.sim.sumo.replay`): each vehicle's body in a stable slot of arrays the
compiled step reads."""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numba import njit

from enn_traffic.config import Scenario
from enn_traffic.core.errors import InputError
from enn_traffic.core.geometry import body_corners
from enn_traffic.sumo.command import to_heading
from enn_traffic.sumo.simulation import (
    FAR,
    ROW_ANGLE,
    ROW_LENGTH,
    ROW_NUMBER,
    ROW_SLOT,
    ROW_WIDTH,
    ROW_X,
    ROW_Y,
    Simulation,
)
from enn_traffic.sumo.states import no_traffic_error, warm_up


@njit(cache=True)
def fill_frame(rows, ids, corners, centres) -> float:
    """One step's slot arrays (ids (S,), corners (S, 4, 2: front-right, front-left, rear-left,
    rear-right), centres (S, 2)) from the rows of :meth:`Simulation.read`: every slot empty,
    then each vehicle's body in its slot, from its front bumper's middle, navigation angle,
    length and width. Returns the largest body's half diagonal."""
    ids[:] = -1
    corners[:] = 0.0
    centres[:] = FAR
    radius = 0.0
    for i in range(rows.shape[0]):
        slot = int(rows[i, ROW_SLOT])
        length, width = rows[i, ROW_LENGTH], rows[i, ROW_WIDTH]
        ids[slot] = int(rows[i, ROW_NUMBER])
        body_corners(rows[i, ROW_X], rows[i, ROW_Y], to_heading(rows[i, ROW_ANGLE]), length,
                     width, corners[slot])
        centres[slot, 0] = 0.5 * (corners[slot, 0, 0] + corners[slot, 2, 0])
        centres[slot, 1] = 0.5 * (corners[slot, 0, 1] + corners[slot, 2, 1])
        radius = max(radius, 0.5 * math.hypot(length, width))
    return radius


@dataclass(frozen=True)
class Recording:
    """A SUMO run without the learner, step by step from the end of the warm-up: slot arrays
    ``ids`` (T, S), ``corners`` (T, S, 4, 2), ``centres`` (T, S, 2); the largest body's
    bounding radius; the mean number of vehicles on the network; and each vehicle's SUMO id
    and type, by the number ``ids`` holds."""

    ids: np.ndarray
    corners: np.ndarray
    centres: np.ndarray
    radius: float
    mean_vehicles: float
    names: tuple[str, ...] = ()
    types: tuple[str, ...] = ()


RECORDED_BYTES = 8 + 8 * 8 + 2 * 8  # a vehicle's slot, its corners and its centre, a step
MAX_RECORDING_BYTES = 4 * 2**30


def slot_arrays(steps: int, slots: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Empty slot arrays: ids (steps, slots) all -1, corners, and centres far out of range."""
    return (np.full((steps, slots), -1, dtype=np.int64), np.zeros((steps, slots, 4, 2)),
            np.full((steps, slots, 2), FAR))


def read_frame(simulation: Simulation, row: int, slots: tuple) -> tuple[tuple, float]:
    """SUMO's vehicles now into row ``row`` of the slot arrays ``slots`` (ids, corners,
    centres), which double in width while a vehicle's slot lies beyond them. Returns the slot
    arrays (the same, or grown) and the largest body's half diagonal."""
    rows = simulation.read()
    ids, corners, centres = slots
    while simulation.slots_used > ids.shape[1]:
        grown = slot_arrays(ids.shape[0], 2 * ids.shape[1])
        for new, old in zip(grown, (ids, corners, centres), strict=True):
            new[:, : old.shape[1]] = old
        ids, corners, centres = grown
    return (ids, corners, centres), fill_frame(rows, ids[row], corners[row], centres[row])


def record(scenario: Scenario, seed: int, steps: int, state: Path | None = None,
           empty: bool = False) -> Recording:
    """Run SUMO for the warm-up (or load its ``state``) and then ``steps`` steps; keep steps
    0..steps. An InputError if no vehicle is on the network at any of them, unless
    ``empty`` (a recording of the first steps only, whose traffic may come later)."""
    simulation = Simulation(scenario, seed, state)
    frames = []
    try:
        if state is None:
            warm_up(simulation)
        for t in range(steps + 1):
            if t:
                simulation.step()
            frames.append(simulation.read())
    finally:
        simulation.close()
    if not empty and not any(len(rows) for rows in frames):
        raise no_traffic_error(scenario, steps)
    size = (steps + 1) * simulation.slots_used * RECORDED_BYTES
    if size > MAX_RECORDING_BYTES:
        raise InputError(f"a replayed situation of {steps + 1:,} steps among "
                         f"{simulation.slots_used:,} SUMO vehicles would take {size / 2**30:.1f} "
                         f"GiB (at most {MAX_RECORDING_BYTES / 2**30:.0f}); lower "
                         'episode.max_steps, or use traffic.mode = "closed-loop"',
                         scenario.source, "episode.max_steps")
    ids, corners, centres = slot_arrays(steps + 1, simulation.slots_used)
    radius = max((fill_frame(rows, ids[t], corners[t], centres[t])
                  for t, rows in enumerate(frames)), default=0.0)
    mean_vehicles = float((ids >= 0).sum(axis=1).mean())
    return Recording(ids, corners, centres, radius, mean_vehicles, tuple(simulation.names),
                     tuple(simulation.types))
