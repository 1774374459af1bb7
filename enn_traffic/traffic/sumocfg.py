"""A SUMO configuration file (``.sumocfg``) as SUMO reads it: the network, route and
additional files it names (relative to the file), and its begin and end times.

SUMO itself runs the configuration (``sumo -c``); this module reads only what the learner
needs to know beforehand (where the track is, when traffic starts and ends) and checks that
every file it names exists, so that a broken configuration is a clear error naming the file
and the option, not a SUMO failure later (docs/sumo.md, "Your own SUMO scenario").
"""

from __future__ import annotations

import contextlib
import re
import xml.etree.ElementTree as ElementTree
from dataclasses import dataclass
from pathlib import Path

from enn_traffic.errors import InputError

FILE_OPTIONS = ("net-file", "route-files", "additional-files")


@dataclass(frozen=True)
class SumoConfig:
    """What a ``.sumocfg`` names: absolute paths, and times in seconds (None: not set)."""

    path: Path
    net_file: Path | None
    route_files: tuple[Path, ...]
    additional_files: tuple[Path, ...]
    begin: float | None
    end: float | None


def parse_time(text: str) -> float:
    """A SUMO time value: seconds (``"25200"``) or ``[[D:]H:]M:S`` (``"7:00:00"``)."""
    parts = text.strip().split(":")
    if not 1 <= len(parts) <= 4:
        raise ValueError(text)
    seconds = 0.0
    for part, unit in zip(reversed(parts), (1, 60, 3600, 86400), strict=False):
        seconds += float(part) * unit
    return seconds


def _option(root: ElementTree.Element, name: str) -> str | None:
    """The value of option ``name`` anywhere in the configuration (sections are optional in
    SUMO's format: ``<input><net-file value=.../></input>`` or ``<net-file value=.../>``)."""
    for element in root.iter(name):
        value = element.get("value", element.get("v"))
        if value is not None:
            return value
    return None


def read_sumocfg(path: Path) -> SumoConfig:
    """Read ``path``; every file it names must exist (InputError naming the option)."""
    try:
        root = ElementTree.parse(path).getroot()
    except (ElementTree.ParseError, OSError) as exc:
        raise InputError(f"not a readable SUMO configuration: {exc}", path) from None
    files: dict[str, tuple[Path, ...]] = {}
    for option in FILE_OPTIONS:
        value = _option(root, option)
        names = [n for n in re.split(r"[,\s]+", value or "") if n]
        resolved = tuple((path.parent / name).resolve() for name in names)
        for name, file in zip(names, resolved, strict=True):
            if not file.is_file():
                raise InputError(f"names a file that does not exist: {name} ({file})", path,
                                 option)
        files[option] = resolved
    times = {}
    for option in ("begin", "end"):
        value = _option(root, option)
        try:
            times[option] = None if value is None else parse_time(value)
        except ValueError:
            raise InputError(f"not a SUMO time: {value!r}", path, option) from None
    begin, end = times["begin"], times["end"]
    if begin is not None and end is not None and end >= 0 and end <= begin:
        raise InputError(f"end ({end:g} s) is not after begin ({begin:g} s)", path, "end")
    net = files["net-file"][0] if files["net-file"] else None
    return SumoConfig(path, net, files["route-files"], files["additional-files"], begin, end)


def departure_span(route_files: list[Path] | tuple[Path, ...]) -> tuple[float, float] | None:
    """The earliest and latest departure (vehicles, trips, persons, flows' begin) in route
    files, for error messages; None if they hold none."""
    departures = []
    for file in route_files:
        try:
            for _, element in ElementTree.iterparse(file):
                tag = element.tag
                time = element.get("begin") if tag == "flow" else element.get("depart")
                if tag in ("vehicle", "trip", "person", "flow") and time is not None:
                    # "triggered", "containerTriggered": no fixed time
                    with contextlib.suppress(ValueError):
                        departures.append(parse_time(time))
                element.clear()
        except (ElementTree.ParseError, OSError):
            continue
    return (min(departures), max(departures)) if departures else None
