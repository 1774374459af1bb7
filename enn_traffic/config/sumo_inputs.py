"""What a scenario asks of SUMO: its ``.sumocfg`` as read, begin and start times, the step
cap, the route files, and every file SUMO reads."""

from __future__ import annotations

import functools
import hashlib
import math
from pathlib import Path

from enn_traffic.config.scenario import Scenario
from enn_traffic.core.cache import content_digest, file_stamp
from enn_traffic.roads.sumocfg import SumoConfig, read_sumocfg, with_includes


@functools.lru_cache(maxsize=16)
def _config(path: Path, *stamp: int) -> SumoConfig:
    return read_sumocfg(path)


def sumo_config(scenario: Scenario) -> SumoConfig | None:
    """The scenario's ``.sumocfg`` as read (None without one), read again once edited."""
    sumocfg = scenario.traffic.sumocfg
    if sumocfg is None:
        return None
    try:
        stamp = file_stamp(sumocfg)
    except OSError:
        return read_sumocfg(sumocfg)  # the error says what is wrong
    return _config(sumocfg, *stamp)


def begin_time(scenario: Scenario) -> float:
    """SUMO time at which the traffic starts: ``traffic.begin_s``, else the ``.sumocfg``'s
    begin, else 0."""
    config = sumo_config(scenario)
    if scenario.traffic.begin_s is not None:
        return scenario.traffic.begin_s
    return config.begin if config is not None and config.begin is not None else 0.0


def learner_start_time(scenario: Scenario) -> float:
    """SUMO time at which the learner starts: ``warmup_s`` after the begin."""
    return begin_time(scenario) + scenario.traffic.warmup_s


def episode_steps(scenario: Scenario) -> int:
    """The step cap of a life among this traffic: ``episode.max_steps``, or fewer when the
    ``.sumocfg`` ends the simulation sooner (its ``end``)."""
    config = sumo_config(scenario)
    limit = scenario.episode.max_steps
    if config is not None and config.end is not None and config.end >= 0:
        left = (config.end - learner_start_time(scenario)) / scenario.vehicle.dt
        limit = min(limit, max(int(math.floor(left + 1e-9)), 1))
    return limit


def route_files(scenario: Scenario) -> list[Path]:
    """The route files SUMO runs: the ``.sumocfg``'s, then ``traffic.routes``."""
    config = sumo_config(scenario)
    return [*(config.route_files if config is not None else ()), *scenario.traffic.routes]


def read_files(scenario: Scenario) -> list[Path]:
    """Every file a scenario reads, each once: its tracks' networks, its route files, and a
    ``.sumocfg`` with every file its options name (network, routes, additional files, a state
    to load, edge weights ...), and every file these ``<include>``; with several tracks,
    each track's own. What a cache or a resumed run is keyed by, besides the settings."""
    parts = ([scenario.on_track(i) for i in range(len(scenario.tracks))]
             if isinstance(scenario.track, list) else [scenario])
    files: list[Path] = []
    for part in parts:
        files += [track.net for track in part.tracks if track.net is not None]
        files += list(part.traffic.routes)
        config = sumo_config(part)
        if config is not None:
            files += config.read_files
    return with_includes(files)


def scenario_digest(scenario: Scenario) -> str:
    """SHA-256 of a scenario's settings and of the bytes of every file it reads
    (:func:`read_files`): what identifies it, whatever its name, and wherever its files are
    (a file is known by its name and bytes, not its folder)."""
    files = read_files(scenario)
    settings = scenario.to_toml()
    for file in sorted(files, key=lambda f: -len(str(f))):
        settings = settings.replace(str(file), file.name)
    digest = hashlib.sha256(settings.encode())
    for file in files:
        digest.update(f"{file.name}:{content_digest(file)}".encode())
    return digest.hexdigest()
