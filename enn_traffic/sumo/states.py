"""The warm-up before the learner starts: simulated, or simulated once and saved as a SUMO
state that later starts load (:func:`warm_state`; docs/sumo.md, "Warm up once"), and the
check that traffic ever reaches the learner's world (docs/sumo.md, "No silent empty
traffic")."""

from __future__ import annotations

import contextlib
import fcntl
import functools
import hashlib
import math
import os
from collections.abc import Iterator
from pathlib import Path

import libsumo

from enn_traffic.config import (
    Scenario,
    begin_time,
    learner_start_time,
    read_files,
    route_files,
    sumo_config,
)
from enn_traffic.core.cache import cache_folder, content_digest, file_stamp, writable_folder
from enn_traffic.core.errors import InputError
from enn_traffic.core.io import gzip_problem, max_input_bytes
from enn_traffic.core.progress import bar, slow_step
from enn_traffic.roads.sumocfg import departure_span
from enn_traffic.sumo.command import traffic_key
from enn_traffic.sumo.simulation import Simulation


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
    load or edge weights, and every file they ``<include>``: :func:`~enn_traffic.config.
    read_files`), begin, warm-up and step length, and SUMO's version."""
    digests = [f"{file}:{content_digest(file)}" for file in read_files(scenario)]
    return [*digests, repr(begin_time(scenario)), repr(scenario.traffic.warmup_s),
            scenario.traffic.drivers.model_dump_json(), str(STATE_VERSION),
            repr(scenario.vehicle.dt), libsumo.getVersion()[1]]


def state_folder() -> Path:
    """Where saved warm-ups are kept: ``$ENN_TRAFFIC_SUMO_STATES``, else ``sumo-states/`` in
    the user's own cache folder (:func:`~enn_traffic.core.cache.cache_folder`; read at every call,
    so that worker processes, which inherit the environment, use the same folder); where that
    cannot be written, in the temporary folder."""
    folder = os.environ.get(STATE_FOLDER_VARIABLE)
    chosen = Path(folder) if folder else cache_folder() / "sumo-states"
    return writable_folder(chosen, "sumo-states")


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
    with _simulating(path):
        if kept_state(path):  # another process simulated it while this one waited
            return path
        partial = path.with_name(f"{path.name.split('.')[0]}.{os.getpid()}.partial.xml.gz")
        simulation = Simulation(scenario, seed, save_rng=keep_rng, keeps_outputs=False)
        try:
            warm_up(simulation)
            with slow_step("saving the warm-up"):
                simulation.save_state(partial)
            os.replace(partial, path)  # whole or not at all
        finally:
            simulation.close()
            partial.unlink(missing_ok=True)  # a failed or interrupted save leaves nothing
    return path


@contextlib.contextmanager
def _simulating(path: Path) -> Iterator[None]:
    """Hold the lock of the warm-up ``path`` (a file beside it, ``.NAME.lock``) while the
    block runs: of processes that need the same warm-up at once, one simulates it and the
    others wait for it, then load it. Where no lock can be taken (a read-only folder, which
    the save would fail in anyway), the block runs unlocked."""
    try:
        descriptor = os.open(path.with_name(f".{path.name}.lock"),
                             os.O_RDWR | os.O_CREAT | os.O_NOFOLLOW, 0o644)
    except OSError:
        yield
        return
    try:
        with slow_step("waiting for another process's warm-up of the same traffic"):
            fcntl.flock(descriptor, fcntl.LOCK_EX)
        yield
    finally:
        os.close(descriptor)  # releases the lock


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
                      traffic_key(scenario))


def first_traffic(scenario: Scenario, seed: int, state: Path | None, steps: int) -> int:
    """Steps after the learner's start until a SUMO vehicle is on the network (at most
    ``steps``; an InputError if none ever is). A check, not a situation: its outputs are
    not kept."""
    simulation = Simulation(scenario, seed, state, keeps_outputs=False)
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
