"""SUMO background traffic through libsumo (DESIGN.md "SUMO").

SUMO runs a scenario's route files (or its ``.sumocfg``) on the track's network with a fixed
seed per traffic situation. After ``warmup_s`` of SUMO time the learner starts, and each step
every SUMO vehicle's position, angle, length and width become a body for the rangefinder and
the collision test (:mod:`enn_traffic.sim.replay`).

Pose convention: SUMO reports a vehicle's front-bumper middle and its navigation angle (degrees,
0 = north, clockwise); ours is the same point with the heading in radians, 0 = east,
counter-clockwise: ``heading = radians(90 - angle)``.

- :func:`record` runs SUMO once without the learner and keeps every step (replay mode).
- :func:`closed_loop_episode` puts the learner into SUMO each step (``moveToXY`` with
  keepRoute=2, speed and lane-change modes 0) so that SUMO traffic reacts to it.

libsumo holds one simulation per process; every function here starts and closes its own.
"""

from __future__ import annotations

import contextlib
import math
import tempfile
from dataclasses import dataclass
from pathlib import Path

import libsumo
import numpy as np
from numba import njit

from enn_traffic.errors import InputError
from enn_traffic.scenario import Scenario
from enn_traffic.sim.collide import body_corners
from enn_traffic.sim.replay import FAR

LEARNER = "enn_learner"
_POSITION, _ANGLE = libsumo.VAR_POSITION, libsumo.VAR_ANGLE
_LENGTH, _WIDTH = libsumo.VAR_LENGTH, libsumo.VAR_WIDTH
_VARIABLES = [_POSITION, _ANGLE, _LENGTH, _WIDTH]
MAX_SLOTS = 4096  # vehicles on the network at once


@njit(cache=True)
def to_heading(angle_deg: float) -> float:
    """SUMO navigation angle (degrees, 0 = north, clockwise) to our heading (radians, 0 = east,
    counter-clockwise), wrapped to (-pi, pi]."""
    heading = math.radians(90.0 - angle_deg)
    return math.pi - (math.pi - heading) % (2.0 * math.pi)


def to_angle(heading: float) -> float:
    """Our heading (radians) to SUMO's navigation angle (degrees in [0, 360))."""
    return (90.0 - math.degrees(heading)) % 360.0


@njit(cache=True)
def _bodies(values, corners, centres) -> None:
    """Body corners (n, 4, 2: front-right, front-left, rear-left, rear-right) and centres
    (n, 2) of SUMO vehicles from rows (x, y, navigation angle, length, width), where (x, y)
    is the front bumper's middle."""
    for i in range(values.shape[0]):
        heading = to_heading(values[i, 2])
        body_corners(values[i, 0], values[i, 1], heading, values[i, 3], values[i, 4], corners[i])
        centres[i, 0] = 0.5 * (corners[i, 0, 0] + corners[i, 2, 0])
        centres[i, 1] = 0.5 * (corners[i, 0, 1] + corners[i, 2, 1])


def sumo_command(scenario: Scenario, seed: int, error_log: Path) -> list[str]:
    """The SUMO command line of a scenario's traffic with ``seed``."""
    traffic = scenario.traffic
    source = ["-c", str(traffic.sumocfg)] if traffic.sumocfg is not None else []
    if traffic.routes:
        source += ["-r", ",".join(str(r) for r in traffic.routes)]
    return [
        "sumo", *source, "-n", str(scenario.track.net),
        "--seed", str(seed), "--step-length", f"{scenario.vehicle.dt:g}",
        "--begin", "0", "--no-step-log", "true", "--no-warnings", "true",
        "--collision.action", "none",  # collisions with the learner are ours (DESIGN.md)
        "--error-log", str(error_log),
    ]  # fmt: skip


def _key(scenario: Scenario) -> str:
    return "traffic.sumocfg" if scenario.traffic.sumocfg is not None else "traffic.routes"


class Simulation:
    """One libsumo run of a scenario's traffic: start, step, and the bodies of its vehicles in
    stable slots (a vehicle keeps its slot while it is on the network)."""

    def __init__(self, scenario: Scenario, seed: int):
        self.scenario = scenario
        self._log = tempfile.NamedTemporaryFile("r", suffix=".log", prefix="enn-sumo-")  # noqa: SIM115 (open for the run)
        command = sumo_command(scenario, seed, Path(self._log.name))
        try:
            libsumo.start(command)
        except Exception as exc:  # libsumo raises its own exception types
            self._fail("SUMO failed to start", exc)
        self.slots: dict[str, int] = {}
        self.numbers: dict[str, int] = {}
        self.following = False
        self._free = list(range(MAX_SLOTS - 1, -1, -1))

    def _fail(self, what: str, exc: Exception | None = None) -> None:
        detail = self._log.read().strip().replace("\n", "; ") or str(exc or "")
        self.close()
        raise InputError(f"{what}: {detail}", self.scenario.source, _key(self.scenario))

    def step(self, count: int = 1) -> None:
        try:
            for _ in range(count):
                libsumo.simulationStep()
                if not self.following:
                    for vehicle in libsumo.simulation.getDepartedIDList():
                        libsumo.vehicle.subscribe(vehicle, _VARIABLES)
        except Exception as exc:
            self._fail("SUMO stopped", exc)

    def read(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """The vehicles on the network now, the learner excepted: their slots, numbers (unique
        within the run), body corners (n, 4, 2) and centres (n, 2). Once :meth:`follow_learner`
        was called, only the vehicles within its reach of the learner."""
        if self.following:
            results = libsumo.vehicle.getContextSubscriptionResults(LEARNER)
        else:
            results = libsumo.vehicle.getAllSubscriptionResults()
        results.pop(LEARNER, None)
        if len(results) != len(self.slots) or any(v not in self.slots for v in results):
            self._assign_slots(results)
        slots = np.fromiter((self.slots[v] for v in results), np.int64, len(results))
        numbers = np.fromiter((self.numbers[v] for v in results), np.int64, len(results))
        values = np.array([(*value[_POSITION], value[_ANGLE], value[_LENGTH], value[_WIDTH])
                           for value in results.values()], dtype=np.float64).reshape(-1, 5)
        corners, centres = np.empty((len(values), 4, 2)), np.empty((len(values), 2))
        _bodies(values, corners, centres)
        return slots, numbers, corners, centres

    def _assign_slots(self, present) -> None:
        """Free the slots of vehicles that left; give arriving vehicles a slot and a number."""
        for vehicle in [v for v in self.slots if v not in present]:
            self._free.append(self.slots.pop(vehicle))
        for vehicle in present:
            if vehicle not in self.slots:
                if not self._free:
                    self._fail(f"more than {MAX_SLOTS} vehicles on the network at once")
                self.slots[vehicle] = self._free.pop()
                self.numbers[vehicle] = len(self.numbers)

    def follow_learner(self, reach: float) -> None:
        """From now on read only the vehicles within ``reach`` of the learner (a context
        subscription: SUMO then reports a few vehicles per step instead of all of them)."""
        for vehicle in libsumo.vehicle.getIDList():
            libsumo.vehicle.unsubscribe(vehicle)
        libsumo.vehicle.subscribeContext(LEARNER, libsumo.CMD_GET_VEHICLE_VARIABLE, reach,
                                         _VARIABLES)
        self.following = True

    @staticmethod
    def largest_radius() -> float:
        """Half the diagonal of the largest vehicle type SUMO knows (a bounding radius)."""
        return max(0.5 * math.hypot(libsumo.vehicletype.getLength(kind),
                                    libsumo.vehicletype.getWidth(kind))
                   for kind in libsumo.vehicletype.getIDList())

    def close(self) -> None:
        with contextlib.suppress(Exception):  # not started, or already closed
            libsumo.close()
        self._log.close()


@dataclass(frozen=True)
class Recording:
    """A SUMO run without the learner, step by step from the end of the warm-up: slot arrays
    ``ids`` (T, S), ``corners`` (T, S, 4, 2), ``centres`` (T, S, 2); the largest body's
    bounding radius; the mean number of vehicles on the network."""

    ids: np.ndarray
    corners: np.ndarray
    centres: np.ndarray
    radius: float
    mean_vehicles: float


def warmup_steps(scenario: Scenario) -> int:
    return round(scenario.traffic.warmup_s / scenario.vehicle.dt)


def slot_arrays(steps: int, slots: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Empty slot arrays: ids (steps, slots) all -1, corners, and centres far out of range."""
    return (np.full((steps, slots), -1, dtype=np.int64), np.zeros((steps, slots, 4, 2)),
            np.full((steps, slots, 2), FAR))


def record(scenario: Scenario, seed: int, steps: int) -> Recording:
    """Run SUMO for the warm-up and then ``steps`` steps; keep steps 0..steps."""
    simulation = Simulation(scenario, seed)
    frames = []
    try:
        simulation.step(warmup_steps(scenario))
        for t in range(steps + 1):
            if t:
                simulation.step()
            frames.append(simulation.read())
    finally:
        simulation.close()
    used = max((int(f[0].max()) + 1 for f in frames if len(f[0])), default=0)
    ids, corners, centres = slot_arrays(steps + 1, used)
    for t, (slots, numbers, frame_corners, frame_centres) in enumerate(frames):
        ids[t, slots], corners[t, slots], centres[t, slots] = numbers, frame_corners, frame_centres
    present = ids >= 0
    sizes = np.linalg.norm(corners[:, :, 0] - corners[:, :, 2], axis=-1)
    radius = 0.5 * float(sizes[present].max()) if present.any() else 0.0
    return Recording(ids, corners, centres, radius, float(present.sum(axis=1).mean()))


def add_learner(length: float, width: float, speed: float) -> None:
    """Put the learner into the running SUMO as a vehicle with no route, that obeys no speed
    or lane-change rule and is moved by :func:`move_learner`."""
    kind = LEARNER + "_type"
    libsumo.vehicletype.copy("DEFAULT_VEHTYPE", kind)
    libsumo.vehicletype.setLength(kind, length)
    libsumo.vehicletype.setWidth(kind, width)
    libsumo.vehicletype.setMaxSpeed(kind, max(speed, 1e-3))
    libsumo.vehicletype.setSpeedDeviation(kind, 0.0)
    libsumo.vehicletype.setImperfection(kind, 0.0)
    libsumo.vehicle.add(LEARNER, "", typeID=kind)
    libsumo.vehicle.setSpeedMode(LEARNER, 0)
    libsumo.vehicle.setLaneChangeMode(LEARNER, 0)


def move_learner(x: float, y: float, heading: float, speed: float) -> None:
    """Place the learner for SUMO's next step (keepRoute=2: anywhere, on a lane or not)."""
    libsumo.vehicle.moveToXY(LEARNER, "", -1, x, y, to_angle(heading), keepRoute=2)
    libsumo.vehicle.setSpeed(LEARNER, speed)
