"""SUMO background traffic through libsumo (docs/sumo.md).

SUMO runs a scenario's ``.sumocfg`` (as SUMO would: its begin time, route and additional
files) or its route files on the track's network with a fixed seed per traffic situation.
``warmup_s`` of SUMO time after the begin, the learner starts, and each step every SUMO
vehicle's position, angle, length and width become a body for the rangefinder and the
collision test (:mod:`enn_traffic.sim.replay`). A warm-up can be simulated once and saved as a
SUMO state file (:func:`warm_state`), which every later start loads instead of simulating it
again.

Pose convention: SUMO reports a vehicle's front-bumper middle and its navigation angle (degrees,
0 = north, clockwise); ours is the same point with the heading in radians, 0 = east,
counter-clockwise: ``heading = radians(90 - angle)``.

- :func:`record` runs SUMO once without the learner and keeps every step (replay mode).
- :func:`add_learner` and :func:`move_learner` put a learner into SUMO each step (``moveToXY``
  with keepRoute=2, speed and lane-change modes 0) so that SUMO traffic reacts to it (closed
  loop).

SUMO reads the user's scenario and never writes into it (docs/sumo.md, "What is written
where"): each start writes into a folder of its own (:func:`output_prefix`), what it prints on
starting and ending goes to a log there, and on closing the log and, when kept, the outputs
move to the scenario's ``sumo_folder``.

libsumo holds one simulation per process; every function here starts and closes its own.
"""

from __future__ import annotations

import contextlib
import functools
import gzip
import hashlib
import math
import os
import re
import shutil
import tempfile
import xml.etree.ElementTree as ElementTree
from dataclasses import dataclass
from pathlib import Path

import libsumo
import numpy as np
from numba import njit

from enn_traffic.cache import cache_folder, content_digest, file_stamp
from enn_traffic.errors import InputError
from enn_traffic.geometry import body_corners
from enn_traffic.io import gzip_problem, max_input_bytes, process_folder, sweep_process_folders
from enn_traffic.progress import bar, console_into, slow_step
from enn_traffic.roads.sumocfg import departure_span
from enn_traffic.scenario import (
    Scenario,
    begin_time,
    learner_start_time,
    read_files,
    route_files,
    sumo_config,
)

LEARNER = "enn_learner"
LEARNER_TYPE = LEARNER + "_type"  # the learners' vehicle type (:func:`add_learner`)
FAR = 1e12  # where an empty slot's centre is put, out of every range
_POSITION, _ANGLE = libsumo.VAR_POSITION, libsumo.VAR_ANGLE
_VARIABLES = [_POSITION, _ANGLE]  # a vehicle's length and width are read once
MAX_SLOTS = 4096  # vehicles on the network at once
# Columns of the rows :meth:`Simulation.read` gives.
ROW_SLOT, ROW_NUMBER, ROW_LENGTH, ROW_WIDTH, ROW_X, ROW_Y, ROW_ANGLE = range(7)
MATCH_M = 10.0  # first radius in which SUMO maps the learner's position to a lane
# The files of a SUMO start's own folder that are enn-traffic's, not the scenario's outputs.
CONSOLE_LOG = "console.log"  # what SUMO printed
ERROR_LOG = "errors.log"  # SUMO's errors, for messages
SSM_FILE = "enn_learner_ssm.xml"  # the learners' SSM devices (closed loop)
STATE_FILE = "enn_state.xml.gz"  # a warm-up being saved
OWN_FILES = (CONSOLE_LOG, ERROR_LOG, SSM_FILE, STATE_FILE)
RUN_LOG = "sumo.log"  # in the scenario's sumo_folder: every start's console, one after another


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


def sumo_command(scenario: Scenario, seed: int, folder: Path, state: Path | None = None,
                 save_rng: bool = False) -> list[str]:
    """The SUMO command line of a scenario's traffic with ``seed``: started at the begin time,
    or from a saved ``state`` (whose time it takes), writing every file into ``folder``
    (:func:`output_prefix`; the ``.sumocfg``'s outputs cut to their file names, its GUI-only
    options emptied). ``save_rng``: states saved by this run keep SUMO's random generators,
    so that a run loading one goes on exactly as this one."""
    traffic = scenario.traffic
    config = sumo_config(scenario)
    source = ["-c", listed(traffic.sumocfg, folder)] if traffic.sumocfg is not None else []
    if traffic.routes:  # added to the .sumocfg's own route files, which -r would replace
        source += ["-r", ",".join(listed(r, folder) for r in route_files(scenario))]
    if state is not None:
        source += ["--load-state", listed(state, folder)]
    elif traffic.begin_s is not None or traffic.sumocfg is None:
        source += ["--begin", f"{begin_time(scenario):g}"]
    if save_rng:
        source += ["--save-state.rng", "true"]
    drivers = traffic.drivers
    if drivers.car_following is not None:
        source += ["--default.carfollowmodel", drivers.car_following]
    if drivers.demand_scale is not None:
        source += ["--scale", f"{drivers.demand_scale:g}"]
    if config is not None:
        for name, value in config.outputs.items():
            if name != "error-log" and name not in (OUTPUT_OPTIONS.get(output)
                                                     for output in traffic.outputs):
                source += [f"--{name}", _file_names(value)]
        for name in config.gui_only:
            source += [f"--{name}", ""]
    for output in traffic.outputs:  # every vehicle's, into the start's folder
        if output in OUTPUT_OPTIONS:
            source += [f"--{OUTPUT_OPTIONS[output]}", f"{output}.xml"]
            if output == "tripinfo":  # a life ends SUMO long before most trips do
                source += ["--tripinfo-output.write-unfinished", "true"]
        else:  # ssm: a device on every vehicle, writing where the learners' write
            source += ["--device.ssm.probability", "1"]
    # Warnings are SUMO's only console output between its start and its end, so they stay off
    # unless its console is shown: the console is then logged around start and end alone,
    # where a switch per step cost 24% of the closed loop's speed (docs/bench.md).
    quiet = [] if scenario.sumo_console else ["--no-warnings", "true"]
    return [
        "sumo", *source, "-n", listed(scenario.track.net, folder),
        "--seed", str(seed), "--step-length", f"{scenario.vehicle.dt:g}",
        "--no-step-log", "true", *quiet,
        "--collision.action", "none",  # collisions with the learner are ours (docs/sumo.md)
        "--output-prefix", output_prefix(folder), "--error-log", ERROR_LOG,
    ]  # fmt: skip


def listed(path: Path, folder: Path) -> str:
    """``path`` as SUMO reads a file option, which it splits at commas: a path with a comma is
    given through a link, in ``folder``, to the folder that holds it (relative paths inside
    the file resolve as from the file itself)."""
    if "," not in str(path):
        return str(path)
    parent = Path(path).resolve().parent
    link = folder / f"input-{hashlib.sha256(str(parent).encode()).hexdigest()[:12]}"
    if not link.is_symlink():
        link.symlink_to(parent, target_is_directory=True)
    return str(link / Path(path).name)


# ``traffic.outputs`` that are SUMO options of their own (``ssm`` is a device, below).
OUTPUT_OPTIONS = {"tripinfo": "tripinfo-output", "fcd": "fcd-output"}
CLIMB = 64  # more folders deep than any place SUMO resolves an output from


def output_prefix(folder: Path) -> str:
    """SUMO's ``--output-prefix`` that puts every file it writes into ``folder``.

    SUMO resolves an output's name against the folder of the file that names it (the
    ``.sumocfg``, an additional file, or the working folder for a command-line option) and
    then prefixes the name's last component. A prefix that climbs to the root (``..`` from
    ``/`` stays at ``/``) and descends to ``folder`` lands there from any such place."""
    return "../" * CLIMB + str(folder.resolve()).lstrip("/") + "/"


def _file_names(value: str) -> str:
    """An output option's value with each file cut to its name (resolved against the
    working folder, which exists, rather than a sub-folder of the scenario that may not)."""
    return ",".join(Path(name).name for name in re.split(r"[,\s]+", value) if name)


def _key(scenario: Scenario) -> str:
    return "traffic.sumocfg" if scenario.traffic.sumocfg is not None else "traffic.routes"


MISSING_FOLDER = ("(an output the scenario names in a sub-folder that does not exist beside "
                  "the file naming it: SUMO reaches enn-traffic's output folder through that "
                  "sub-folder, so it must exist, or the output be named without a folder)")


def _sumo_errors(folder: Path) -> str:
    """What SUMO said went wrong in a start's ``folder``: its error log, else the errors it
    printed (an output it cannot open is printed, not logged), on one line, with the climb
    of :func:`output_prefix` shortened and the usual cause of a missing folder named."""
    lines = []
    for name, only_errors in ((ERROR_LOG, False), (CONSOLE_LOG, True)):
        log = folder / name
        text = log.read_text(errors="replace") if log.is_file() else ""
        lines = [line.strip() for line in text.splitlines()
                 if line.strip() and (not only_errors or line.startswith("Error"))]
        if lines:
            break
    detail = re.sub(r"(\.\./){3,}", ".../", "; ".join(dict.fromkeys(lines)))
    if "Could not build output file" in detail:
        detail += " " + MISSING_FOLDER
    return detail


class Simulation:
    """One libsumo run of a scenario's traffic: start, step, and the bodies of its vehicles in
    stable slots (a vehicle keeps its slot while it is on the network)."""

    running: Simulation | None = None  # libsumo runs one simulation per process

    def __init__(self, scenario: Scenario, seed: int, state: Path | None = None,
                 save_rng: bool = False, extra: tuple[str, ...] = (),
                 learners: tuple[str, ...] = (LEARNER,)):
        if Simulation.running is not None:
            raise RuntimeError(
                f"{scenario.name}: a SUMO is already running in this process (libsumo runs one "
                "at a time): close it first; step several closed-loop environments each in "
                "its own process (gymnasium.make_vec(..., vectorization_mode='async'))")
        self.scenario = scenario
        self.seed = seed
        sweep_process_folders()  # those of killed processes (Ctrl-C, SIGKILL)
        self.folder = process_folder()  # all this start writes
        self._open = True
        Simulation.running = self
        command = sumo_command(scenario, seed, self.folder, state, save_rng)
        if "ssm" in scenario.traffic.outputs and "--device.ssm.file" not in extra:
            extra = (*extra, *ssm_options(()))  # no learner here: every vehicle's device
        try:
            with slow_step(f"starting SUMO on {scenario.name}'s traffic (seed {seed})"), \
                    self.console():
                libsumo.start([*command, *extra])
        except Exception as exc:  # libsumo raises its own exception types
            if state is None:
                self._fail("SUMO failed to start", exc)
            # The state is enn-traffic's own file: say so, not that the user's files are wrong.
            self._fail("SUMO failed to load this warm-up state, which enn-traffic saved (not "
                       "a file of the scenario's: a SUMO bug in saving or loading states; "
                       "delete it to simulate the warm-up again, or set traffic.warmup_s = 0 "
                       "to start without one). SUMO said", exc, where=state)
        # vehicle -> (slot, number, length, width): the first row columns of :meth:`read`
        self.vehicles: dict[str, tuple[int, int, float, float]] = {}
        self.numbered = 0  # vehicles given a number so far
        self.names: list[str] = []  # each numbered vehicle's SUMO id and vehicle type
        self.types: list[str] = []
        self.following = False
        self.learners = learners  # SUMO ids that :meth:`read` leaves out
        self.slots_used = 0  # one more than the highest slot given so far
        self._free = list(range(MAX_SLOTS - 1, -1, -1))
        self._lane_change = scenario.traffic.drivers.lane_change()
        self._set_driver_types()
        for vehicle in libsumo.vehicle.getIDList():  # on the network in a loaded state
            libsumo.vehicle.subscribe(vehicle, _VARIABLES)
            if self._lane_change:
                self._set_lane_change(vehicle)
        self._stepped = False  # libsumo refreshes subscription results only with a step

    def _set_driver_types(self) -> None:
        """``[traffic.drivers]``: the driver-model values on every traffic vehicle type (a
        vehicle of a type takes the type's values, whenever it departs)."""
        drivers = self.scenario.traffic.drivers
        setters = {libsumo.vehicletype.setImperfection: drivers.imperfection,
                   libsumo.vehicletype.setTau: drivers.tau_s,
                   libsumo.vehicletype.setAccel: drivers.accel,
                   libsumo.vehicletype.setDecel: drivers.decel,
                   libsumo.vehicletype.setSpeedFactor: drivers.speed_factor}
        for kind in self._traffic_types():
            for setter, value in setters.items():
                if value is not None:
                    setter(kind, value)

    def _set_lane_change(self, vehicle: str) -> None:
        """``[traffic.drivers]``'s lane-change values on one traffic vehicle (SUMO takes them
        per vehicle only, not from its type)."""
        if vehicle not in self.learners:
            for name, value in self._lane_change.items():
                libsumo.vehicle.setParameter(vehicle, name, value)

    def console(self):
        """SUMO's console into this start's log while inside (shown, with
        ``scenario.sumo_console``): around SUMO's start, end and state saving, where it
        prints; its steps print nothing but warnings, which are off unless shown."""
        if self.scenario.sumo_console:
            return contextlib.nullcontext()
        return console_into(self.folder / CONSOLE_LOG)

    def _fail(self, what: str, exc: Exception | None = None, where: Path | None = None) -> None:
        """Close SUMO and raise what went wrong, with SUMO's own message, naming the
        scenario's traffic key, or ``where`` when a file of enn-traffic's own caused it."""
        detail = _sumo_errors(self.folder)
        self.close()
        if where is not None:
            raise InputError(f"{what}: {detail or exc or ''}", where)
        raise InputError(f"{what}: {detail or exc or ''}", self.scenario.source,
                         _key(self.scenario))

    def step(self, count: int = 1) -> None:
        try:
            for _ in range(count):
                libsumo.simulationStep()
                self._stepped = True
                if self.following:  # unseen vehicles keep their slots until they arrive
                    for vehicle in libsumo.simulation.getArrivedIDList():
                        if vehicle in self.vehicles:
                            self._free.append(self.vehicles.pop(vehicle)[ROW_SLOT])
                else:
                    for vehicle in libsumo.simulation.getDepartedIDList():
                        libsumo.vehicle.subscribe(vehicle, _VARIABLES)
                if self._lane_change:
                    for vehicle in libsumo.simulation.getDepartedIDList():
                        self._set_lane_change(vehicle)
        except Exception as exc:
            self._fail("SUMO stopped", exc)

    def read(self) -> np.ndarray:
        """The vehicles on the network now, the learner excepted, a row each (columns
        ``ROW_*``): slot, number (unique within the run), length, width, front bumper's x and
        y, navigation angle; :func:`fill_frame` makes bodies of them. Once
        :meth:`follow_learner` was called, only the vehicles within its reach of the learner;
        a vehicle keeps its slot and number while it is on the network, in reach or not, so
        that one that left the learner's world (``gone``, :mod:`enn_traffic.sim.replay`)
        stays out of it."""
        if self.following:
            results = libsumo.vehicle.getContextSubscriptionResults(LEARNER)
        else:
            results = libsumo.vehicle.getAllSubscriptionResults()
        if not self._stepped:  # results of the last simulation may linger until a step
            present = set(libsumo.vehicle.getIDList())
            results = {v: value for v, value in results.items() if v in present}
        for learner in self.learners:
            results.pop(learner, None)
        vehicles = self.vehicles
        if len(results) != len(vehicles) or any(v not in vehicles for v in results):
            if not self.following:  # every vehicle on the network is read: absent ones left
                for vehicle in [v for v in vehicles if v not in results]:
                    self._free.append(vehicles.pop(vehicle)[ROW_SLOT])
            self._assign_slots(results)
        return np.array([(*vehicles[v], *value[_POSITION], value[_ANGLE])
                         for v, value in results.items()], dtype=np.float64).reshape(-1, 7)

    def _assign_slots(self, present) -> None:
        """Give the vehicles new to the learner a slot, a number, and their (static) size."""
        for vehicle in present:
            if vehicle not in self.vehicles:
                if not self._free:
                    self._fail(f"more than {MAX_SLOTS} vehicles on the network at once")
                slot = self._free.pop()
                self.slots_used = max(self.slots_used, slot + 1)
                self.vehicles[vehicle] = (slot, self.numbered, libsumo.vehicle.getLength(vehicle),
                                          libsumo.vehicle.getWidth(vehicle))
                self.names.append(vehicle)
                self.types.append(libsumo.vehicle.getTypeID(vehicle))
                self.numbered += 1

    def follow_learner(self, reach: float) -> None:
        """From now on read only the vehicles within ``reach`` of the learner (a context
        subscription: SUMO then reports a few vehicles per step instead of all of them)."""
        for vehicle in libsumo.vehicle.getIDList():
            libsumo.vehicle.unsubscribe(vehicle)
        libsumo.vehicle.subscribeContext(LEARNER, libsumo.CMD_GET_VEHICLE_VARIABLE, reach,
                                         _VARIABLES)
        self.following = True

    @staticmethod
    def _traffic_types() -> list[str]:
        """The vehicle types the traffic may use: the scenario's and DEFAULT_VEHTYPE, not
        SUMO's other built-in defaults (a 135 m train would make every vehicle "near")."""
        return [kind for kind in libsumo.vehicletype.getIDList()
                if (not kind.startswith("DEFAULT_") or kind == "DEFAULT_VEHTYPE")
                and kind != LEARNER_TYPE]

    def largest_radius(self) -> float:
        """A bounding radius: half the diagonal of the largest traffic vehicle type."""
        return max(0.5 * math.hypot(libsumo.vehicletype.getLength(kind),
                                    libsumo.vehicletype.getWidth(kind))
                   for kind in self._traffic_types())

    def largest_speed(self) -> float:
        """The top speed of the fastest traffic vehicle type (SUMO never exceeds it)."""
        return max(libsumo.vehicletype.getMaxSpeed(kind) for kind in self._traffic_types())

    @staticmethod
    def time() -> float:
        """SUMO's simulation time (s)."""
        return libsumo.simulation.getTime()

    @staticmethod
    def vehicle_count() -> int:
        """Vehicles on the network now."""
        return libsumo.vehicle.getIDCount()

    def save_state(self, path: Path) -> None:
        """Save the running SUMO's state to ``path`` (gzipped if it ends in ``.gz``) so that
        it loads again (:func:`make_loadable`)."""
        with self.console():
            libsumo.simulation.saveState(STATE_FILE)  # into the folder, by the output prefix
        written = self.folder / STATE_FILE
        make_loadable(written)
        shutil.move(written, path)

    def close(self, read: tuple[str, ...] = ()) -> dict[str, bytes]:
        """End SUMO. Returns what it wrote into the files ``read`` of its folder (b"" for
        one it did not write); its console log then goes to the scenario's ``sumo_folder``
        and, with ``traffic.sumo_outputs = "keep"``, its outputs too; its folder is deleted."""
        if not self._open:
            return dict.fromkeys(read, b"")
        self._open = False
        Simulation.running = None
        self._ended_at = float("nan")
        with contextlib.suppress(Exception):
            self._ended_at = libsumo.simulation.getTime()
        with contextlib.suppress(Exception), self.console():  # not started, or closed
            libsumo.close()
        contents = {name: (self.folder / name).read_bytes() if (self.folder / name).is_file()
                    else b"" for name in read}
        try:
            self._hand_over()
        finally:
            shutil.rmtree(self.folder, ignore_errors=True)
        return contents

    def _hand_over(self) -> None:
        """This start's console log (appended to ``RUN_LOG``) and kept outputs (a folder of
        their own in ``outputs/``) into the scenario's ``sumo_folder``."""
        target = self.scenario.sumo_folder
        if target is None:
            return
        console = self.folder / CONSOLE_LOG
        printed = console.read_bytes() if console.is_file() else b""
        if target.is_symlink():
            raise InputError("is a link: SUMO's log is written only inside the output folder",
                             target)
        target.mkdir(parents=True, exist_ok=True)
        ended = ("did not start" if math.isnan(self._ended_at)
                 else f"ended at {self._ended_at:g} s")
        try:  # never through a link, out of the output folder
            log = os.open(target / RUN_LOG, os.O_WRONLY | os.O_APPEND | os.O_CREAT
                          | os.O_NOFOLLOW, 0o644)
        except OSError as exc:
            raise InputError(f"cannot write SUMO's log ({exc.strerror}; a link is never "
                             "followed)", target / RUN_LOG) from None
        with open(log, "ab") as handle:  # a block for every start, printed or not
            handle.write(f"== SUMO, seed {self.seed}, {ended}\n".encode()
                         + (printed or b"(SUMO printed nothing)\n"))
        traffic = self.scenario.traffic
        ssm = self.folder / SSM_FILE
        if "ssm" in traffic.outputs and ssm.is_file():  # every vehicle's conflicts, kept
            shutil.copyfile(ssm, self.folder / "ssm.xml")
        outputs = [file for file in self.folder.iterdir() if file.name not in OWN_FILES]
        if outputs and (traffic.sumo_outputs == "keep" or traffic.outputs):
            if (target / "outputs").is_symlink():
                raise InputError("is a link: SUMO's outputs are kept only inside the output "
                                 "folder", target / "outputs")
            (target / "outputs").mkdir(parents=True, exist_ok=True)
            kept = Path(tempfile.mkdtemp(dir=target / "outputs", prefix=f"seed{self.seed}-"))
            for file in outputs:
                shutil.move(file, kept / file.name)


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


def warmup_steps(scenario: Scenario) -> int:
    return round(scenario.traffic.warmup_s / scenario.vehicle.dt)


def warm_up(simulation: Simulation) -> None:
    """Step a freshly started SUMO through the scenario's warm-up, with a bar in SUMO seconds
    on a wait of more than a second (a city's long warm-up takes minutes)."""
    scenario = simulation.scenario
    steps, dt = warmup_steps(scenario), scenario.vehicle.dt
    chunk = max(1, round(10.0 / dt))  # the bar moves every 10 s of SUMO time
    span = _departures(tuple(route_files(scenario)))
    last = math.inf if span is None else span[1]
    with bar(round(steps * dt, 6), f"SUMO warm-up, seed {simulation.seed}", "SUMO s",
             bar_format="{desc}: {n:.0f}/{total:.0f} SUMO s [{elapsed}<{remaining}, "
                        "{rate_fmt}]") as progress:
        done = 0
        while done < steps:
            count = min(chunk, steps - done)
            simulation.step(count)
            done += count
            progress.update(count * dt)
            now = libsumo.simulation.getTime()
            if now > last and libsumo.simulation.getMinExpectedNumber() == 0:
                # nothing on the network, nothing left to depart: the learner's start would
                # find no traffic, however long SUMO went on
                raise no_traffic_error(scenario, 0, emptied=now)


@functools.lru_cache(maxsize=8)
def _departures(files: tuple[Path, ...]) -> tuple[float, float] | None:
    """:func:`departure_span` of route files, read once per process (a warm-up runs per
    situation)."""
    return departure_span(files)


STATE_FOLDER_VARIABLE = "ENN_TRAFFIC_SUMO_STATES"
STATE_VERSION = 6  # raised when the code that simulates and saves a warm-up changes


def _inputs_key(scenario: Scenario) -> list[str]:
    """What a warm-up depends on: the SHA-256 of every file SUMO reads (network, route and
    additional files, the ``.sumocfg`` and every file its options name, such as a state to
    load or edge weights, and every file they ``<include>``: :func:`~enn_traffic.scenario.
    read_files`), begin, warm-up and step length, and SUMO's version."""
    digests = [f"{file}:{content_digest(file)}" for file in read_files(scenario)]
    return [*digests, repr(begin_time(scenario)), repr(scenario.traffic.warmup_s),
            scenario.traffic.drivers.model_dump_json(), str(STATE_VERSION),
            repr(scenario.vehicle.dt), libsumo.getVersion()[1]]


def state_folder() -> Path:
    """Where saved warm-ups are kept: ``$ENN_TRAFFIC_SUMO_STATES``, else ``sumo-states/`` in
    the user's own cache folder (:func:`~enn_traffic.cache.cache_folder`; read at every call,
    so that worker processes, which inherit the environment, use the same folder)."""
    folder = os.environ.get(STATE_FOLDER_VARIABLE)
    return Path(folder) if folder else cache_folder() / "sumo-states"


def state_path(scenario: Scenario, seed: int, keep_rng: bool) -> Path:
    """Where :func:`warm_state` keeps the state of ``seed`` (named by everything it depends
    on), whether or not it is there yet."""
    key = hashlib.sha256("\n".join([*_inputs_key(scenario), str(seed), str(keep_rng)])
                         .encode()).hexdigest()[:24]
    return state_folder() / f"{key}.xml.gz"


def warm_state(scenario: Scenario, seed: int, keep_rng: bool) -> Path:
    """A SUMO state file of the scenario's traffic ``warmup_s`` after its begin, simulated with
    ``seed`` once and kept on disk (in :func:`state_folder`, named by everything it depends
    on).
    ``keep_rng``: the state holds SUMO's random generators, so a run loading it goes on as the
    warm-up would have (one traffic situation's own warm-up); without, a run loading it goes
    on by its own seed (a warm-up shared by several situations)."""
    path = state_path(scenario, seed, keep_rng)
    if kept_state(path):
        return path
    path.parent.mkdir(parents=True, exist_ok=True)
    partial = path.with_name(f"{path.name.split('.')[0]}.{os.getpid()}.partial.xml.gz")
    simulation = Simulation(scenario, seed, save_rng=keep_rng)
    try:
        warm_up(simulation)
        with slow_step("saving the warm-up"):
            simulation.save_state(partial)
        os.replace(partial, path)  # whole or not at all, whichever process wrote it first
    finally:
        simulation.close()
        partial.unlink(missing_ok=True)  # a failed or interrupted save leaves nothing
    return path


def kept_state(path: Path) -> bool:
    """Is the saved warm-up ``path`` there, and whole? One cut short or damaged (a full disk,
    a copy broken off, a flipped bit that fails gzip's CRC) is deleted, so that it is
    simulated again rather than handed to SUMO, which would refuse it."""
    try:
        stamp = file_stamp(path)
    except OSError:
        return False
    if gzip_problem(path, max_input_bytes(), *stamp) is None:
        return True
    with contextlib.suppress(OSError):
        path.unlink()
    return False


EMPTY_TL_STATE = re.compile(r'(<tlLogic\b[^>]*?) state=""')
DRIVE_WAYS = re.compile(r'^[ \t]*<(?:sub)?[dD]riveWay\b[^>]*/>[ \t]*\n', re.M)


def make_loadable(path: Path) -> None:
    """Make the state SUMO just saved to ``path`` load again: SUMO 1.28 saves states that it
    then refuses to load, in two ways.

    - An actuated traffic light (``type="actuated"``, as every OSM-built city has) is saved
      with ``state=""`` ("Attribute 'state' in definition of tlLogic '...' is empty"). The
      empty attribute is left out: SUMO then takes the state of the saved phase.
    - The drive ways of rail signals (a city with trams or trains) load once or twice, and
      then crash libsumo at the next start in the same process (a segmentation fault in
      ``simulation.start``, issue 60). They are left out: SUMO builds them again as the
      trains come, and only which train had reserved a track block at the moment of saving
      is lost.
    - With a demand scaled above 1 (``--scale``), SUMO's copies of a vehicle share its
      embedded route (``!id``), which the state may leave out ("The route '!id' for vehicle
      'id.1' is not known"). The routes a saved vehicle names but the state lacks are written
      into it, with the edges of a vehicle that drives it (SUMO is still running: the
      vehicles are asked only when a route is missing)."""
    opener = gzip.open if path.name.endswith(".gz") else open
    with opener(path, "rt", encoding="utf-8") as file:
        text = file.read()
    repaired = DRIVE_WAYS.sub("", EMPTY_TL_STATE.sub(r"\1", text))
    defined = set(re.findall(r'<route id="([^"]*)"', repaired))
    drivers = {route: vehicle for vehicle, route
               in re.findall(r'<vehicle id="([^"]*)"[^>]*? route="([^"]*)"', repaired)
               if route not in defined}
    if drivers:
        routes = "".join(f'    <route id="{route}" state="0" '
                         f'edges="{" ".join(libsumo.vehicle.getRoute(vehicle))}"/>\n'
                         for route, vehicle in sorted(drivers.items()))
        first = repaired.index("<snapshot")
        first = repaired.index("\n", first) + 1  # routes come first in the snapshot
        repaired = repaired[:first] + routes + repaired[first:]
    if repaired != text:
        with opener(path, "wt", encoding="utf-8") as file:
            file.write(repaired)


def no_traffic_error(scenario: Scenario, steps: int, emptied: float | None = None
                     ) -> InputError:
    """Why a scenario's traffic never reached the learner's world: no SUMO vehicle on the
    network from the learner's start to the end of its life, or (``emptied``) SUMO's network
    emptied for good at that time, before the learner's start."""
    start = learner_start_time(scenario)
    end = start + steps * scenario.vehicle.dt
    config = sumo_config(scenario)
    begin = f"the learner starts at {start:g} s: warmup_s = {scenario.traffic.warmup_s:g} s "
    if scenario.traffic.begin_s is not None:
        begin += f"after traffic.begin_s = {begin_time(scenario):g} s"
    elif config is not None and config.begin is not None:
        begin += f"after {config.path.name}'s begin, {config.begin:g} s"
    else:
        begin += "after SUMO time 0"
    span = departure_span(route_files(scenario))
    departures = ("the route files name no departure" if span is None else
                  f"the route files' departures span {span[0]:g}-{span[1]:g} s")
    what = (f"no SUMO vehicle is on the network from {start:g} s to {end:g} s of SUMO time"
            if emptied is None else f"SUMO's last vehicle left the network at {emptied:g} s "
            f"with none left to depart, before the learner's start")
    return InputError(f"{what}, so the learner would drive without traffic ({begin}; "
                      f"{departures}); set traffic.begin_s or warmup_s", scenario.source,
                      _key(scenario))


def first_traffic(scenario: Scenario, seed: int, state: Path | None, steps: int) -> int:
    """Steps after the learner's start until a SUMO vehicle is on the network (at most
    ``steps``; an InputError if none ever is)."""
    simulation = Simulation(scenario, seed, state)
    try:
        if state is None:
            warm_up(simulation)
        for t in range(steps + 1):
            if simulation.vehicle_count():
                return t
            simulation.step()
    finally:
        simulation.close()
    raise no_traffic_error(scenario, steps)


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


# SUMO's SSM device on the learner (closed loop): conflicts with the vehicles around it,
# where time-to-collision falls below 1.5 s, the deceleration to avoid a crash exceeds
# 3 m/s², or the post-encroachment time falls below 2 s (docs/sumo.md, "Safety figures").
SSM_THRESHOLDS = {"TTC": 1.5, "DRAC": 3.0, "PET": 2.0}
SSM_RANGE_M = 50.0


def ssm_options(learners: tuple[str, ...] = (LEARNER,)) -> tuple[str, ...]:
    """SUMO options that equip the learners (their SUMO ids) with SSM devices writing to
    ``SSM_FILE`` in the start's folder (read it with ``Simulation.close(read=...)``)."""
    explicit = ("--device.ssm.explicit", ",".join(learners)) if learners else ()
    return (*explicit, "--device.ssm.measures", " ".join(SSM_THRESHOLDS),
            "--device.ssm.thresholds", " ".join(f"{v:g}" for v in SSM_THRESHOLDS.values()),
            "--device.ssm.range", f"{SSM_RANGE_M:g}", "--device.ssm.trajectories", "false",
            "--device.ssm.file", SSM_FILE, *SSM_DEFAULTS)


# SSM's other options at SUMO's defaults, set so that SUMO does not print for every learner
# that it "does not supply vehicle parameter 'device.ssm....'" (between steps, on the
# terminal).
SSM_DEFAULTS = ("--device.ssm.extratime", "5", "--device.ssm.geo", "false",
                "--device.ssm.mdrac.prt", "1", "--device.ssm.write-positions", "false",
                "--device.ssm.write-lane-positions", "false",
                "--device.ssm.exclude-conflict-types", "")


@dataclass(frozen=True)
class Conflicts:
    """What the learner's SSM device wrote: conflicts (encounters in which some measure passed
    its threshold), the lowest TTC seen (inf: none), and the conflicts by measure."""

    count: int = 0
    min_ttc: float = math.inf
    ttc: int = 0
    drac: int = 0
    pet: int = 0


def _conflicts(output: bytes) -> list:
    """The learners' conflict elements of an SSM output (none for an empty one): with
    ``traffic.outputs = ["ssm"]`` every vehicle has a device, writing into the same file."""
    try:
        conflicts = ElementTree.fromstring(output).findall("conflict")
    except ElementTree.ParseError:
        return []
    return [c for c in conflicts if (c.get("ego") or LEARNER).startswith(LEARNER)]


def _measure(conflict, tag: str, attribute: str = "value") -> float | None:
    """An attribute of a conflict's measure (``minTTC``, ``maxDRAC``, ``PET``), or None when it
    has none or it is "NA"."""
    element = conflict.find(tag)
    try:
        return float(element.get(attribute)) if element is not None else None
    except (TypeError, ValueError):  # "NA"
        return None


def read_conflicts(output: bytes) -> Conflicts:
    """Read an SSM output (an empty one: no conflict)."""
    conflicts = _conflicts(output)
    ttc = [v for c in conflicts if (v := _measure(c, "minTTC")) is not None]
    drac = [v for c in conflicts if (v := _measure(c, "maxDRAC")) is not None]
    pet = [v for c in conflicts if (v := _measure(c, "PET")) is not None]
    return Conflicts(len(conflicts), min(ttc, default=math.inf),
                     sum(v < SSM_THRESHOLDS["TTC"] for v in ttc),
                     sum(v > SSM_THRESHOLDS["DRAC"] for v in drac),
                     sum(v < SSM_THRESHOLDS["PET"] for v in pet))


def ttc_conflict_times(output: bytes) -> np.ndarray:
    """The SUMO times of the conflicts in an SSM output whose lowest time-to-collision fell
    below its threshold."""
    return np.array([_measure(c, "minTTC", "time") for c in _conflicts(output)
                     if (ttc := _measure(c, "minTTC")) is not None
                     and ttc < SSM_THRESHOLDS["TTC"]], dtype=np.float64)


def learner_id(index: int) -> str:
    """The SUMO id of learner ``index`` (the first, or only, is :data:`LEARNER`)."""
    return LEARNER if index == 0 else f"{LEARNER}_{index}"


def add_learner(length: float, width: float, speed: float, vehicle: str = LEARNER) -> None:
    """Put a learner into the running SUMO as a vehicle with no route, that obeys no speed
    or lane-change rule and is moved by :func:`move_learner` (the learners share one
    vehicle type, made with the first)."""
    kind = LEARNER_TYPE
    if kind not in libsumo.vehicletype.getIDList():
        libsumo.vehicletype.copy("DEFAULT_VEHTYPE", kind)
        libsumo.vehicletype.setLength(kind, length)
        libsumo.vehicletype.setWidth(kind, width)
        libsumo.vehicletype.setMaxSpeed(kind, max(speed, 1e-3))
        libsumo.vehicletype.setSpeedDeviation(kind, 0.0)
        libsumo.vehicletype.setImperfection(kind, 0.0)
        # The least speed factor that lets it go its own speed on every lane it may drive
        # (moveToXY places it at that speed whatever the lane's limit; SSM sees it at that
        # speed from its insertion on). A far larger factor makes SUMO plan its stopping
        # distance across the city every step (a factor of 100 cost 876 ms a step on a
        # 9,700-lane city, docs/sumo.md "Learners at SUMO's pace").
        libsumo.vehicletype.setSpeedFactor(kind, learner_speed_factor(speed))
    try:
        libsumo.vehicle.add(vehicle, "", typeID=kind, departSpeed=f"{speed:g}")
        libsumo.vehicle.setSpeedMode(vehicle, 0)
        libsumo.vehicle.setLaneChangeMode(vehicle, 0)
        libsumo.vehicle.setSpeed(vehicle, speed)  # for its first step; then SUMO derives it
    except libsumo.TraCIException as exc:
        if Simulation.running is None:
            raise
        Simulation.running._fail(f"SUMO refused the learner {vehicle!r}", exc)


def learner_speed_factor(speed: float) -> float:
    """``speed`` over the lowest speed limit of the running SUMO's lanes that allow passenger
    cars, junctions' internal lanes too (at least 1): the learners' type then has room to go
    ``speed`` on each."""
    limits = [libsumo.lane.getMaxSpeed(lane) for lane in libsumo.lane.getIDList()
              if _allows_cars(lane)]
    return max(1.0, speed / min(limits)) if limits else 1.0


def _allows_cars(lane: str) -> bool:
    allowed, disallowed = libsumo.lane.getAllowed(lane), libsumo.lane.getDisallowed(lane)
    return ("passenger" in allowed or not allowed) and "passenger" not in disallowed


def remove_learner(vehicle: str = LEARNER) -> None:
    """Take a learner out of the running SUMO, its subscription first (libsumo would go on
    asking for the variables of a vehicle it no longer knows and stop)."""
    libsumo.vehicle.unsubscribe(vehicle)
    libsumo.vehicle.remove(vehicle)


def move_learner(x: float, y: float, heading: float, vehicle: str = LEARNER) -> None:
    """Place the learner for SUMO's next step (keepRoute=2: anywhere, on a lane or not); SUMO
    takes its speed from the distance moved. Lanes are looked for within MATCH_M first (the
    learner is on the drivable area, so one is that near; a wider search costs twice as
    much), then anywhere."""
    try:
        libsumo.vehicle.moveToXY(vehicle, "", -1, x, y, to_angle(heading), keepRoute=2,
                                 matchThreshold=MATCH_M)
    except libsumo.TraCIException:
        libsumo.vehicle.moveToXY(vehicle, "", -1, x, y, to_angle(heading), keepRoute=2,
                                 matchThreshold=1e6)
