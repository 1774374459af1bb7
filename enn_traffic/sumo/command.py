"""How enn-traffic starts SUMO and what it calls things there: the command line of a
scenario's traffic (:func:`sumo_command`), the folder every start writes into
(:func:`output_prefix`; docs/sumo.md, "What is written where"), the learner's SUMO ids and the
files of a start that are enn-traffic's own, and the pose convention.

SUMO reports a vehicle's front-bumper middle and its navigation angle (degrees, 0 = north,
clockwise); ours is the same point with the heading in radians, 0 = east, counter-clockwise:
``heading = radians(90 - angle)``."""

from __future__ import annotations

import functools
import gzip
import hashlib
import math
import re
from pathlib import Path

from numba import njit

from enn_traffic.config import Scenario, begin_time, route_files, sumo_config
from enn_traffic.core.cache import file_stamp
from enn_traffic.core.errors import InputError

LEARNER = "enn_learner"
LEARNER_TYPE = LEARNER + "_type"  # the learners' vehicle type (:func:`add_learner`)
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
    if state is not None:  # begun at the state's time, where SUMO would warn it differs
        source += ["--load-state", listed(state, folder), "--begin", state_time(state)]
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


SNAPSHOT_TIME = re.compile(rb'<snapshot\b[^>]*?\btime="([^"]+)"')


def state_time(path: Path) -> str:
    """The SUMO time a saved state was written at, as it wrote it (its ``<snapshot>``, after
    the configuration SUMO writes first): read once per process while the file is unchanged,
    every closed-loop start loading the same warm-up."""
    return _state_time(path, *file_stamp(path))


@functools.lru_cache(maxsize=64)
def _state_time(path: Path, *stamp: int) -> str:
    head = b""
    with gzip.open(path, "rb") if path.name.endswith(".gz") else open(path, "rb") as file:
        while len(head) < 1 << 20:  # a block at a time, until the snapshot's tag
            block = file.read(1 << 14)
            head += block
            found = SNAPSHOT_TIME.search(head)
            if found is not None:
                return found.group(1).decode()
            if not block:
                break
    raise InputError("not a SUMO state: no <snapshot time=...> in its first megabyte "
                     "(a warm-up enn-traffic saved; delete it to simulate it again)", path)


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


def traffic_key(scenario: Scenario) -> str:
    """The key that names a scenario's SUMO traffic, for an error about it."""
    return "traffic.sumocfg" if scenario.traffic.sumocfg is not None else "traffic.routes"


MISSING_FOLDER = ("(an output the scenario names in a sub-folder that does not exist beside "
                  "the file naming it: SUMO reaches enn-traffic's output folder through that "
                  "sub-folder, so it must exist, or the output be named without a folder)")


def sumo_errors(folder: Path) -> str:
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
