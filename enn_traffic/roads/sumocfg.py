"""A SUMO configuration file (``.sumocfg``) as SUMO reads it: the network, route and
additional files it names (relative to the file), its begin and end times, and the options
that write files or serve SUMO's GUI only.

SUMO itself runs the configuration (``sumo -c``); this module reads only what the learner
needs to know beforehand (where the track is, when traffic starts and ends, what SUMO would
write where) and checks that every file it names exists, so that a broken configuration is a
clear error naming the files and the options, not a SUMO failure later (docs/sumo.md, "Your own
SUMO scenario"). Which options write files, and which are the GUI's, SUMO's own option
template says (:func:`sumo_options`), for the SUMO version installed.
"""

from __future__ import annotations

import contextlib
import functools
import gzip
import os
import re
import stat
import subprocess
import tempfile
import xml.etree.ElementTree as ElementTree
import zlib
from dataclasses import dataclass, field
from pathlib import Path

import sumolib

from enn_traffic.core.cache import file_stamp
from enn_traffic.core.errors import InputError
from enn_traffic.core.io import check_input_file
from enn_traffic.roads.xmlread import iterparse, parse_root

FILE_OPTIONS = ("net-file", "route-files", "additional-files")


@dataclass(frozen=True)
class SumoOption:
    """One of SUMO's options, as its template describes it."""

    name: str  # the canonical name
    section: str  # input, output, report, gui_only ...
    kind: str  # FILE, STR, BOOL, TIME ...

    @property
    def reads_file(self) -> bool:
        """Does setting it make SUMO read a file (a network, routes, a state, weights ...)?"""
        return (self.kind == "FILE" and self.section != "gui_only" and not self.writes_file
                and not self.name.startswith("save-"))

    @property
    def writes_file(self) -> bool:
        """Does setting it make SUMO write a file (an output, a log, a saved state)?"""
        if self.section in ("gui_only", "input") or self.name.endswith("input-file"):
            return False
        if self.kind == "FILE":
            return (self.section in ("output", "report") or "output" in self.name
                    or self.name.startswith("save-"))
        return self.name.startswith("device.") and self.name.endswith(".file")


@functools.cache
def sumo_options() -> dict[str, SumoOption]:
    """Every option of the installed SUMO, by its name and by each of its synonyms (from
    ``sumo --save-template``)."""
    with tempfile.TemporaryDirectory(prefix="enn-sumo-template-") as folder:
        template = Path(folder) / "template.xml"
        subprocess.run([sumolib.checkBinary("sumo"), "--save-template", str(template)],
                       capture_output=True, check=True)
        root = ElementTree.parse(template).getroot()
    options = {}
    for section in root:
        for element in section:
            option = SumoOption(element.tag, section.tag, element.get("type", ""))
            for name in [element.tag, *(element.get("synonymes") or "").split()]:
                options[name] = option
    return options


# Options a configuration may not set, and why (docs/sumo.md, "Your own SUMO scenario").
# (Its output-prefix is harmless: the learner's own replaces it, sumo.output_prefix.)
REFUSED = {
    "remote-port": "opens a TraCI port and waits for a client",
    "num-clients": "waits for further TraCI clients",
    "save-configuration": "makes SUMO write a configuration file instead of simulating",
    "save-template": "makes SUMO write a template instead of simulating",
    "save-schema": "makes SUMO write a schema instead of simulating",
    "configuration-file": "reads a further configuration",
    "help": "makes SUMO print its help and end",
    "version": "makes SUMO print its version and end",
    "print-options": "makes SUMO print its options",
    "output-suffix": "moves every file SUMO writes into another folder",
    "save-state.suffix": "moves the states SUMO saves into another folder",
}
_OFF = {"", "0", "false", "off", "no"}


def _harmless(name: str, value: str) -> bool:
    """Is a refused option set to a value that changes nothing?"""
    value = value.strip().lower()
    if name == "num-clients":
        return value in ("", "1")
    if name.endswith("suffix"):
        return "/" not in value and "\\" not in value  # a suffix of the file name alone
    return value in _OFF


@dataclass(frozen=True)
class SumoConfig:
    """What a ``.sumocfg`` names: absolute paths, and times in seconds (None: not set);
    ``outputs``: the options it sets that write files (canonical name: value as written);
    ``gui_only``: the options of its ``<gui_only>`` section, which the command-line SUMO
    does not need (a missing GUI settings file would stop it)."""

    path: Path
    net_file: Path | None
    route_files: tuple[Path, ...]
    additional_files: tuple[Path, ...]
    begin: float | None
    end: float | None
    outputs: dict[str, str] = field(default_factory=dict)
    gui_only: tuple[str, ...] = ()
    # Every other file SUMO reads for it (a state to load, edge weights ...): option: files.
    other_inputs: dict[str, tuple[Path, ...]] = field(default_factory=dict)

    @property
    def read_files(self) -> list[Path]:
        """Every file SUMO reads for this configuration: itself, its network, route and
        additional files and the other files its options name (not yet their includes)."""
        files = [self.path, *([self.net_file] if self.net_file else []), *self.route_files,
                 *self.additional_files]
        return files + [file for named in self.other_inputs.values() for file in named]


def parse_time(text: str) -> float:
    """A SUMO time value: seconds (``"25200"``) or ``[[D:]H:]M:S`` (``"7:00:00"``)."""
    parts = text.strip().split(":")
    if not 1 <= len(parts) <= 4:
        raise ValueError(text)
    seconds = 0.0
    for part, unit in zip(reversed(parts), (1, 60, 3600, 86400), strict=False):
        seconds += float(part) * unit
    return seconds


def _settings(root: ElementTree.Element) -> tuple[dict[str, str], list[str]]:
    """Every option the configuration sets (name as written: value) outside its
    ``<gui_only>`` section, and the names set inside it. Sections are optional in SUMO's
    format: ``<input><net-file value=.../></input>`` or ``<net-file value=.../>``."""
    settings, gui_only = {}, []
    for child in root:
        inner = [child] if child.get("value", child.get("v")) is not None else list(child)
        for element in inner:
            value = element.get("value", element.get("v"))
            if value is None:
                continue
            if child.tag == "gui_only":
                gui_only.append(element.tag)
            else:
                settings[element.tag] = value
    return settings, gui_only


def read_sumocfg(path: Path) -> SumoConfig:
    """Read ``path``; every file it names must exist (one InputError naming every missing
    file and its option)."""
    check_input_file(path, "SUMO configuration")
    try:
        root = parse_root(path)
    except (ElementTree.ParseError, OSError, LookupError, ValueError) as exc:
        raise InputError(f"not a readable SUMO configuration: {exc}", path) from None
    settings, gui_only = _settings(root)
    known = sumo_options()
    canonical = {known[name].name if name in known else name: value
                 for name, value in settings.items()}
    for name, value in canonical.items():
        if name in REFUSED and not _harmless(name, value):
            raise InputError(f"{name} = {value!r} {REFUSED[name]}; remove it (the learner "
                             "runs SUMO in its own process, as its only client, and decides "
                             "where SUMO writes)", path, name)
    files: dict[str, tuple[Path, ...]] = {}
    missing = []
    read = [*FILE_OPTIONS, *(name for name in canonical if name not in FILE_OPTIONS
                             and name in known and known[name].reads_file
                             and not name.endswith("-path"))]  # phemlight-path: a folder
    for option in read:
        names = [n for n in re.split(r"[,\s]+", canonical.get(option) or "") if n]
        resolved = tuple((path.parent / name).resolve() for name in names)
        for name, file in zip(names, resolved, strict=True):
            if not file.exists():
                missing.append((option, name, file))
            else:
                check_input_file(file, "the file", path, option)
        files[option] = resolved
    if missing:
        options = list(dict.fromkeys(option for option, _, _ in missing))
        listed = "; ".join(f"{option}: {name} ({file})" if len(options) > 1
                           else f"{name} ({file})" for option, name, file in missing)
        plural = ("a file that does not exist" if len(missing) == 1
                  else f"{len(missing)} files that do not exist")
        raise InputError(f"names {plural}: {listed}", path, ", ".join(options))
    for option in read:
        if option != "net-file":  # a network is read whole, and checked, where it is used
            check_included(files[option], path, option)
    times = {}
    for option in ("begin", "end"):
        value = canonical.get(option)
        try:
            times[option] = None if value is None else parse_time(value)
        except ValueError:
            raise InputError(f"not a SUMO time: {value!r}", path, option) from None
    begin, end = times["begin"], times["end"]
    if begin is not None and end is not None and end >= 0 and end <= begin:
        raise InputError(f"end ({end:g} s) is not after begin ({begin:g} s)", path, "end")
    net = files["net-file"][0] if files["net-file"] else None
    outputs = {name: value for name, value in canonical.items()
               if name in known and known[name].writes_file and value.strip()}
    return SumoConfig(path, net, files["route-files"], files["additional-files"], begin, end,
                      outputs, tuple(known[name].name if name in known else name
                                     for name in gui_only),
                      {option: files[option] for option in read if option not in FILE_OPTIONS})


def departure_span(route_files: list[Path] | tuple[Path, ...]) -> tuple[float, float] | None:
    """The earliest and latest departure in route files: vehicles', trips' and persons'
    ``depart``, flows' ``begin`` and ``end`` (inf for a flow without an ``end``, which SUMO
    keeps sending); None if they hold none."""
    departures = []
    for file in route_files:
        try:
            for _, element in iterparse(file):
                tag = element.tag
                if tag in ("flow", "personFlow"):
                    times = [element.get("begin", "0"), element.get("end", "inf")]
                elif tag in ("vehicle", "trip", "person"):
                    times = [element.get("depart")]
                else:
                    times = []
                for time in times:
                    # "triggered", "containerTriggered": no fixed time
                    with contextlib.suppress(ValueError, TypeError):
                        departures.append(parse_time(time))
                element.clear()
        except (ElementTree.ParseError, OSError):
            continue
    return (min(departures), max(departures)) if departures else None


_INCLUDE = re.compile(rb"<include\s[^>]*?href\s*=\s*[\"']([^\"']+)[\"']")


def with_includes(files: list[Path] | tuple[Path, ...]) -> list[Path]:
    """``files`` and every file their ``<include href="..."/>`` elements name (relative to the
    including file), at any depth, each once: every file SUMO reads for them."""
    found: list[Path] = []
    pending = [Path(file) for file in files]
    while pending:
        file = pending.pop(0)
        if file in found:
            continue
        found.append(file)
        try:
            pending += _included(file, *file_stamp(file))
        except OSError:
            continue
    return found


def check_included(files: list[Path] | tuple[Path, ...], source: Path, key: str) -> None:
    """``files`` and every file they ``<include>``, at any depth, checked as SUMO's XML inputs
    before SUMO reads them: an included file as an input (:func:`~enn_traffic.core.io.
    check_input_file`: no pipe, device, folder or oversized file, the error naming the
    including file), and every one as well-formed XML (:func:`xml_problem`), so that a cut or
    garbled file, an encoding no reader knows or an entity bomb, on which SUMO fails late or
    hangs, is refused at once. ``files`` themselves are checked as inputs by the caller
    (``source``, ``key``: where they were named)."""
    seen: set[Path] = set()
    pending: list[tuple[Path, tuple[Path, ...]]] = [(Path(file), ()) for file in files]
    while pending:
        file, chain = pending.pop(0)
        parent = chain[-1] if chain else None
        if file in chain:  # SUMO crashes on a file that includes itself (exit -11)
            raise InputError(f"includes {file.name}, which includes it again: "
                             + " -> ".join(f.name for f in (*chain[chain.index(file):], file)),
                             parent, "include")
        if file in seen:
            continue
        seen.add(file)
        if parent is not None:
            check_input_file(file, f"the file it includes ({file.name})", parent, "include")
        try:
            stamp = file_stamp(file)
        except OSError:
            continue
        problem = xml_problem(file, *stamp)
        if problem:
            raise InputError(f"{file.name} is not readable XML: {problem}",
                             parent or source, "include" if parent else key)
        pending += [(inner, (*chain, file)) for inner in _included(file, *stamp)]


MAX_XML_DEPTH = 64  # SUMO's own files nest a few levels (routes, vehicle, route, stop)


@functools.lru_cache(maxsize=256)
def xml_problem(file: Path, *stamp: int) -> str | None:
    """Why ``file`` (gzipped when it ends in ``.gz``) is not well-formed XML, or None; read
    once per process while it is unchanged. Python's parser refuses entity bombs (its limit
    on amplification) and external entities."""
    opener = gzip.open if file.name.endswith(".gz") else open
    depth = 0
    try:
        with opener(file, "rb") as handle:
            for event, element in iterparse(handle, ("start", "end")):
                if event == "start":
                    depth += 1
                    if depth > MAX_XML_DEPTH:
                        return (f"elements nested more than {MAX_XML_DEPTH} deep (SUMO's "
                                "files nest a few levels; SUMO takes minutes on such a file)")
                else:
                    depth -= 1
                    element.clear()
    except (ElementTree.ParseError, LookupError, ValueError, OSError, EOFError,
            zlib.error) as exc:
        return str(exc)
    return None


@functools.lru_cache(maxsize=256)
def _included(file: Path, *stamp: int) -> list[Path]:
    """The files ``file``'s ``<include>`` elements name, read once while it is unchanged (a
    file that is not a regular one, a pipe or a device, is not read: it names none)."""
    try:
        if not stat.S_ISREG(os.stat(file).st_mode):
            return []
        data = file.read_bytes()
    except OSError:
        return []
    return [(file.parent / href.decode(errors="replace")).resolve()
            for href in _INCLUDE.findall(data)] if b"<include" in data else []
