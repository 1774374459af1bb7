"""One libsumo run of a scenario's traffic (:class:`Simulation`): start, step, and the
bodies of its vehicles in stable slots; saving its state so that it loads again.

libsumo holds one simulation per process; every function of :mod:`enn_traffic.sumo` starts
and closes its own."""

from __future__ import annotations

import atexit
import contextlib
import gzip
import math
import os
import re
import shutil
import tempfile
from pathlib import Path

import libsumo
import numpy as np

from enn_traffic.config import Scenario
from enn_traffic.core.errors import InputError
from enn_traffic.core.io import process_folder, sweep_process_folders
from enn_traffic.core.progress import console_into, slow_step
from enn_traffic.sumo.command import (
    CONSOLE_LOG,
    LEARNER,
    LEARNER_TYPE,
    OWN_FILES,
    RUN_LOG,
    SSM_FILE,
    STATE_FILE,
    sumo_command,
    sumo_errors,
    traffic_key,
)
from enn_traffic.sumo.ssm import ssm_options

FAR = 1e12  # where an empty slot's centre is put, out of every range
_POSITION, _ANGLE = libsumo.VAR_POSITION, libsumo.VAR_ANGLE
_VARIABLES = [_POSITION, _ANGLE]  # a vehicle's length and width are read once
MAX_SLOTS = 4096  # vehicles on the network at once
# Columns of the rows :meth:`Simulation.read` gives.
ROW_SLOT, ROW_NUMBER, ROW_LENGTH, ROW_WIDTH, ROW_X, ROW_Y, ROW_ANGLE = range(7)
MATCH_M = 10.0  # first radius in which SUMO maps the learner's position to a lane


class Simulation:
    """One libsumo run of a scenario's traffic: start, step, and the bodies of its vehicles in
    stable slots (a vehicle keeps its slot while it is on the network)."""

    running: Simulation | None = None  # libsumo runs one simulation per process

    def __init__(self, scenario: Scenario, seed: int, state: Path | None = None,
                 save_rng: bool = False, extra: tuple[str, ...] = (),
                 learners: tuple[str, ...] = (LEARNER,), keeps_outputs: bool = True):
        if Simulation.running is not None:
            raise RuntimeError(
                f"{scenario.name}: a SUMO is already running in this process (libsumo runs one "
                "at a time): close it first; step several closed-loop environments each in "
                "its own process (gymnasium.make_vec(..., vectorization_mode='async'))")
        self.scenario = scenario
        self.seed = seed
        self.keeps_outputs = keeps_outputs  # False: a warm-up's, which holds no situation
        sweep_process_folders()  # those of killed processes (Ctrl-C, SIGKILL)
        self.folder = process_folder()  # all this start writes
        self._open = True
        Simulation.running = self
        command = sumo_command(scenario, seed, self.folder, state, save_rng)
        if "ssm" in scenario.traffic.outputs and "--device.ssm.file" not in extra:
            extra = (*extra, *ssm_options())  # how the devices of every vehicle write
        # SSM devices write into this start's folder: a learner added here may carry one
        self.has_ssm_options = "--device.ssm.file" in extra
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
        detail = sumo_errors(self.folder)
        self.close()
        if where is not None:
            raise InputError(f"{what}: {detail or exc or ''}", where)
        raise InputError(f"{what}: {detail or exc or ''}", self.scenario.source,
                         traffic_key(self.scenario))

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
        that one that left the learner's world (``gone``, :mod:`enn_traffic.sim.sumo.replay`)
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
        if outputs and self.keeps_outputs and (traffic.sumo_outputs == "keep"
                                               or traffic.outputs):
            if (target / "outputs").is_symlink():
                raise InputError("is a link: SUMO's outputs are kept only inside the output "
                                 "folder", target / "outputs")
            (target / "outputs").mkdir(parents=True, exist_ok=True)
            kept = Path(tempfile.mkdtemp(dir=target / "outputs", prefix=f"seed{self.seed}-"))
            for file in outputs:
                shutil.move(file, kept / file.name)


EMPTY_TL_STATE = re.compile(r'(<tlLogic\b[^>]*?) state=""')
DRIVE_WAYS = re.compile(r'^[ \t]*<(?:sub)?[dD]riveWay\b[^>]*/>[ \t]*\n', re.M)


@atexit.register
def _close_at_exit() -> None:
    """A SUMO still running as the process ends (a closed-loop environment never closed, an
    exception before its close) is closed, so that its folder goes with it."""
    if Simulation.running is not None:
        with contextlib.suppress(Exception):
            Simulation.running.close()


def make_loadable(path: Path) -> None:
    """Make the state SUMO just saved to ``path`` load again: SUMO 1.28 saves states that it
    then refuses to load, in two ways.

    - An actuated traffic light (``type="actuated"``, as every OSM-built city has) is saved
      with ``state=""`` ("Attribute 'state' in definition of tlLogic '...' is empty"). The
      empty attribute is left out: SUMO then takes the state of the saved phase.
    - The drive ways of rail signals (a city with trams or trains) load once or twice, and
      then crash libsumo at the next start in the same process (a segmentation fault in
      ``simulation.start``). They are left out: SUMO builds them again as the
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
