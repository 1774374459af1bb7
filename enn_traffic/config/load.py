"""Reading a scenario file: TOML, paths resolved against the file (or inside an installed
package, ``pkg:NAME/...``), its SUMO files checked, ``start_lane = "auto"`` resolved."""

from __future__ import annotations

import importlib.util
import re
import tomllib
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import NamedTuple

from enn_traffic.config.scenario import Scenario, track_key, validated
from enn_traffic.config.sumo_inputs import route_files, sumo_config
from enn_traffic.config.track import TrackConfig
from enn_traffic.config.vehicle import VehicleConfig
from enn_traffic.core.errors import InputError
from enn_traffic.core.io import check_input_file
from enn_traffic.roads.lanes import auto_lane
from enn_traffic.roads.network import clear_starts, least_start_length, read_net
from enn_traffic.roads.sumocfg import check_included, read_sumocfg

PACKAGE_PREFIX = "pkg:"


def package_file(reference: str) -> Path:
    """``pkg:NAME/inner/path``: a file inside the installed Python package NAME (found without
    importing it), for data that a package ships, such as sumo-rl's city scenarios."""
    name, _, inner = reference.removeprefix(PACKAGE_PREFIX).partition("/")
    try:
        spec = importlib.util.find_spec(name) if name.isidentifier() else None
    except (ImportError, ValueError):
        spec = None
    if spec is None or not spec.submodule_search_locations:
        raise ValueError(f"no installed Python package {name!r} for {reference!r}")
    if ".." in Path(inner).parts or Path(inner).is_absolute():
        raise ValueError(f"{reference!r} leaves the package {name!r}")
    return Path(list(spec.submodule_search_locations)[0]) / inner


def _resolve(path: Path, section, key: str) -> None:
    """Make ``section[key]`` (a path or a list of paths) absolute: relative to ``path``'s
    folder, or inside an installed package (``pkg:NAME/...``)."""
    if not isinstance(section, dict):
        return

    def resolve(value, where: str):
        if not isinstance(value, str):
            return value
        if value.startswith(PACKAGE_PREFIX):
            try:
                return str(package_file(value))
            except ValueError as exc:
                raise InputError(str(exc), path, where) from None
        try:
            return str((path.parent / value).resolve())
        except (ValueError, OSError) as exc:  # a NUL character, a name the system refuses
            raise InputError(f"not a usable path: {exc}", path, where) from None
        except RuntimeError:  # pathlib's word for a loop of symbolic links
            raise InputError(f"{value} is a loop of symbolic links", path, where) from None

    value = section.get(key)
    if isinstance(value, list):
        section[key] = [resolve(v, f"{key}[{i}]") for i, v in enumerate(value)]
    elif value is not None:
        section[key] = resolve(value, key)


def load_scenario(path: str | Path) -> Scenario:
    """Read and validate a scenario; network, route and SUMO configuration paths resolve
    relative to the scenario file (or inside an installed package, ``pkg:NAME/...``). A
    ``.sumocfg`` is read as SUMO reads it, and names the track when ``[track] net`` is left
    out."""
    path = Path(path)
    check_input_file(path, "scenario file")
    try:
        text = path.read_text(encoding="utf-8")
        line = _long_dotted_key(text)
        if line:  # Python's TOML reader takes time quadratic in a key's parts
            raise InputError(f"line {line}: a dotted key of more than {MAX_KEY_PARTS} parts "
                             "(a scenario's keys have at most 4)", path)
        data = tomllib.loads(text)
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise InputError(f"not valid TOML: {exc}", path) from None
    except RecursionError:
        raise InputError("not valid TOML here: tables or lists nested too deeply", path) \
            from None
    except ValueError as exc:  # an integer of more digits than Python converts
        raise InputError(f"not readable TOML here: {exc}", path) from None
    except OSError as exc:
        raise InputError(f"cannot be read: {exc.strerror or exc}", path) from None
    tracks = data.get("track")
    for track in tracks if isinstance(tracks, list) else [tracks]:
        _resolve(path, track, "net")
        if isinstance(track, dict):
            _resolve(path, track.get("traffic"), "routes")
            _resolve(path, track.get("traffic"), "sumocfg")
    _resolve(path, data.get("traffic"), "routes")
    _resolve(path, data.get("traffic"), "sumocfg")
    scenario = validated(data, path.resolve())
    if not isinstance(scenario.track, list):
        return _with_files(scenario, path)
    tracks = []
    for index in range(len(scenario.track)):
        try:
            tracks.append(_with_files(scenario.on_track(index), path).track)
        except InputError as exc:
            raise InputError(exc.message, path,
                             track_key(exc.key, index, scenario.track[index])) from None
    return scenario.model_copy(update={"track": [
        track.model_copy(update={"traffic": listed.traffic})
        for track, listed in zip(tracks, scenario.track, strict=True)]})


MAX_KEY_PARTS = 32
_DOT_IN_KEY = re.compile(r"[A-Za-z_\"'-]\s*\.\s*[A-Za-z_\"'-]")


def _long_dotted_key(text: str) -> int | None:
    """The number of the first line whose key (before any ``=``) has more than
    ``MAX_KEY_PARTS`` dotted parts; dots between digits (numbers) are not counted."""
    for number, line in enumerate(text.splitlines(), 1):
        if len(_DOT_IN_KEY.findall(line.split("=", 1)[0])) >= MAX_KEY_PARTS:
            return number
    return None


def _with_files(scenario: Scenario, path: Path) -> Scenario:
    """Check that a single-track scenario's files exist (a clear error naming the key if
    not), and read its ``.sumocfg``."""
    traffic = scenario.traffic
    for index, route in enumerate(traffic.routes):
        check_input_file(route, "route file", path, f"traffic.routes[{index}]")
        _no_comma(route, path, f"traffic.routes[{index}]")
    given_net = scenario.track is not None and scenario.track.net is not None
    if traffic.sumocfg is not None:
        check_input_file(traffic.sumocfg, "SUMO configuration", path, "traffic.sumocfg")
        scenario = _with_sumocfg(scenario, path)  # names the network when [track] does not
    if scenario.track is not None:
        check_input_file(scenario.track.net, "network file", path, "track.net")
        if traffic.is_sumo:
            _no_comma(scenario.track.net, path, "track.net" if given_net else "traffic.sumocfg")
    check_included(traffic.routes, path, "traffic.routes")
    if scenario.track is not None and scenario.track.start_lane == AUTO:
        scenario = _with_auto_lane(scenario, path)
    return scenario


def _no_comma(file: Path, path: Path, key: str) -> None:
    """SUMO splits a file option at commas: a file whose own name holds one cannot be read
    (a comma in a folder's name is passed through a link: traffic.sumo.listed)."""
    if "," in file.name:
        raise InputError(f"SUMO splits a list of files at commas, so it cannot read "
                         f"{file.name!r}; rename the file", path, key)


AUTO = "auto"  # [track] start_lane = "auto"


@contextmanager
def network_named(scenario: Scenario) -> Iterator[None]:
    """An unreadable network said as the scenario file's ``track.net`` (the network's own file
    in the message), not as a file the user may not know the scenario reads."""
    try:
        yield
    except InputError as exc:
        net = scenario.track.net if isinstance(scenario.track, TrackConfig) else None
        if (exc.key is None and exc.file is not None and net is not None
                and scenario.source is not None and Path(exc.file).resolve() == net.resolve()):
            raise InputError(f"{exc.file}: {exc.message}", scenario.source, "track.net") from None
        raise


def _with_auto_lane(scenario: Scenario, path: Path) -> Scenario:
    """``start_lane = "auto"`` made the lane it stands for (enn_traffic.roads.lanes)."""
    track = scenario.track
    config = sumo_config(scenario)
    additional = config.additional_files if config is not None else ()
    with network_named(scenario):
        read_net(track.net)  # read once per process: auto_lane reads it from memory
    rule = start_rule(track.net, scenario)
    try:
        lane = auto_lane(track.net, route_files(scenario), rule.shortest, additional,
                         clear=rule.clear)
    except InputError as exc:
        raise InputError(f"auto: {exc.message}", path, "track.start_lane") from None
    return scenario.model_copy(update={"track": track.model_copy(update={"start_lane": lane})})


def _with_sumocfg(scenario: Scenario, path: Path) -> Scenario:
    """Check the ``.sumocfg`` and the learner's start time against its begin and end; fill
    ``[track] net`` from it when left out."""
    traffic = scenario.traffic
    config = read_sumocfg(traffic.sumocfg)
    begin = traffic.begin_s if traffic.begin_s is not None else (config.begin or 0.0)
    start = begin + traffic.warmup_s
    if config.end is not None and config.end >= 0 and start >= config.end:
        raise InputError(
            f"the learner would start at {start:g} s (begin {begin:g} s + warmup_s "
            f"{traffic.warmup_s:g} s), not before the end of {traffic.sumocfg.name} "
            f"({config.end:g} s)", path,
            "traffic.begin_s" if traffic.begin_s is not None else "traffic.warmup_s")
    if scenario.track is not None and scenario.track.net is None:
        if config.net_file is None:
            raise InputError(f"[track] net is left out and {traffic.sumocfg.name} names no "
                             "net-file", path, "track.net")
        track = scenario.track.model_copy(update={"net": config.net_file})
        scenario = scenario.model_copy(update={"track": track})
    return scenario


class StartRule(NamedTuple):
    """What ``start_lane = "auto"`` asks of a lane besides its demand: to be ``shortest`` m long
    or longer (:func:`~enn_traffic.roads.network.least_start_length`), and that the body
    at ``start_offset`` along it lie on the road (``clear``,
    :func:`~enn_traffic.roads.network.clear_starts`)."""

    shortest: float
    clear: Callable[[str], bool]


def start_rule(net: Path, scenario: Scenario | None = None) -> StartRule:
    """The :class:`StartRule` of ``scenario`` on ``net`` (by its ``start_offset``, body, road
    surface and fringe), or, without one, of the default ``start_offset`` and body."""
    if scenario is None:
        offset = TrackConfig.model_fields["start_offset"].default
        vehicle, surface, exits = VehicleConfig(), "passenger", True
    else:
        offset, vehicle = scenario.track.start_offset, scenario.vehicle
        surface, exits = scenario.track.surface, scenario.fringe_exits
    return StartRule(least_start_length(offset, vehicle.length),
                     clear_starts(net, offset, vehicle.length, vehicle.width, surface, exits))


def sumo_sources(path: Path) -> tuple[Path, list[Path], list[Path], StartRule]:
    """The network, route files and additional files of a ``.sumocfg``, or of a scenario of
    one track (its SUMO traffic's; no route files without SUMO traffic), and the rule a lane
    its learner may start on meets (:func:`start_rule`; a ``.sumocfg``'s: by the default
    ``start_offset`` and body)."""
    if path.suffix == ".sumocfg":
        if not path.is_file():
            raise InputError("SUMO configuration not found", path)
        config = read_sumocfg(path)
        if config.net_file is None:
            raise InputError("names no net-file", path, "net-file")
        return (config.net_file, list(config.route_files), list(config.additional_files),
                start_rule(config.net_file))
    scenario = load_scenario(path)
    if isinstance(scenario.track, list):
        raise InputError("give a scenario of one track (or its .sumocfg)", path, "track")
    if scenario.track is None:
        raise InputError("a lane-keeping scenario has no SUMO network", path, "lane_keeping")
    config = sumo_config(scenario)
    return (scenario.track.net, route_files(scenario) if scenario.traffic.is_sumo else [],
            list(config.additional_files) if config is not None else [],
            start_rule(scenario.track.net, scenario))
