"""A whole scenario file (:class:`Scenario`): its sections, the checks that span several of
them, the settings derived from them, and validation errors said as the file's keys."""

from __future__ import annotations

import re
from pathlib import Path
from typing import Annotated

import numpy as np
import tomli_w
from pydantic import Discriminator, Field, Tag, ValidationError, field_validator, model_validator

from enn_traffic.config.base import MAX_SEED, FilePath, Section
from enn_traffic.config.lane_keeping import LaneKeepingConfig
from enn_traffic.config.learning import CrowdConfig, EpisodeConfig, GAConfig, NetworkConfig
from enn_traffic.config.sensor import SensorConfig
from enn_traffic.config.track import TrackConfig
from enn_traffic.config.traffic import SUMO, TrafficConfig
from enn_traffic.config.vehicle import VehicleConfig
from enn_traffic.core.errors import InputError
from enn_traffic.core.neural import NetworkSpec

MAX_POPULATION_GENES = 50_000_000  # 0.4 GB a copy of the population; the GA holds a few


class Scenario(Section):
    """A whole scenario file: a SUMO ``[track]`` (navigation, arena, SUMO traffic), or several
    (``[[track]]``: fitness is the mean over them all, docs/scenarios.md "Several tracks"), or
    a highway-env ``[lane_keeping]`` road."""

    name: str = Field(
        min_length=1, max_length=100, pattern=r"^[A-Za-z0-9_.-]+$", description="run name "
        "(letters, digits, `_.-`; not `.` or `..`); the default output folder")
    description: str = Field("", description="free text")
    seed: int = Field(
        0, ge=0, le=MAX_SEED,
        description="seed of the run's random generator; same seed, same run")
    track: Annotated[
        Annotated[TrackConfig, Tag("one")] | Annotated[list[TrackConfig], Tag("several")],
        Discriminator(lambda value: "several" if isinstance(value, list) else "one"),
    ] | None = None
    lane_keeping: LaneKeepingConfig | None = None
    vehicle: VehicleConfig = VehicleConfig()
    sensor: SensorConfig = SensorConfig()
    network: NetworkConfig = NetworkConfig()
    ga: GAConfig = GAConfig()
    episode: EpisodeConfig = EpisodeConfig()
    traffic: TrafficConfig = TrafficConfig()
    crowd: CrowdConfig = CrowdConfig()
    source: FilePath | None = Field(None, exclude=True)
    # Set by the command that runs the scenario, not by its file: where SUMO's console log and
    # kept outputs go (none: nowhere), and whether SUMO's console is shown instead.
    sumo_folder: FilePath | None = Field(None, exclude=True)
    sumo_console: bool = Field(False, exclude=True)

    @field_validator("name")
    @classmethod
    def _not_a_folder_step(cls, name: str) -> str:
        if set(name) == {"."}:
            raise ValueError(f"{name!r} names a folder step, not a run: use letters or digits")
        return name

    @model_validator(mode="after")
    def _one_task(self) -> Scenario:
        if (self.track is None) == (self.lane_keeping is None):
            raise ValueError("give exactly one of [track] (a SUMO network) or [lane_keeping]")
        return self

    @model_validator(mode="after")
    def _lane_keeping_reads_its_own(self) -> Scenario:
        """Lane keeping (§5.6) drives highway-env's vehicle and reads its camera: a
        [vehicle], [sensor] or [traffic] key set there would do nothing."""
        if self.lane_keeping is not None:
            for name, default in (("vehicle", VehicleConfig()), ("sensor", SensorConfig()),
                                  ("traffic", TrafficConfig())):
                if getattr(self, name) != default:
                    raise ValueError(
                        f"[{name}] is not read by lane keeping, which drives highway-env's "
                        "vehicle and reads its camera ([lane_keeping] lookahead_m, noise_m): "
                        f"remove the [{name}] keys")
        return self

    @model_validator(mode="after")
    def _track_net(self) -> Scenario:
        if (isinstance(self.track, TrackConfig) and self.track.net is None
                and self.traffic.sumocfg is None):
            raise ValueError("track.net: required unless traffic.sumocfg names the network")
        return self

    @model_validator(mode="after")
    def _sumo_sources(self) -> Scenario:
        traffic = self.traffic  # several tracks: each track's own traffic is checked
        if (not isinstance(self.track, list) and traffic.is_sumo and not traffic.routes
                and traffic.sumocfg is None):
            raise ValueError('traffic: strategy "sumo" needs routes (route files) or a sumocfg')
        return self

    @model_validator(mode="after")
    def _traffic_network(self) -> Scenario:
        hidden, traffic = self.network.hidden, self.traffic.network_hidden
        fits = len(hidden) == len(traffic) and all(
            t <= h for t, h in zip(traffic, hidden, strict=True))
        if "random_network" in self.traffic.strategy_list and self.traffic.starts_xy and not fits:
            raise ValueError(f"traffic.network_hidden: random-network traffic {traffic} runs "
                             f"inside the learner's network {hidden}, which needs as many "
                             "hidden layers, each at least as large")
        return self

    @model_validator(mode="after")
    def _spin_rule_spares_driving(self) -> Scenario:
        """Paper §5.3's spin rule judges positions a window of steps apart: a vehicle driving
        straight (diagonally, the worst case) must not count as spinning."""
        step, window = self.vehicle.speed * self.vehicle.dt, self.episode.spin_window
        variance = step**2 * (window**2 - 1) / 24  # evenly spaced on a diagonal, per axis
        if self.lane_keeping is None and variance <= self.episode.spin_variance:
            raise ValueError(
                f"episode.spin_window: a vehicle driving straight covers {step * window:g} m "
                f"in {window} steps, so its positions may vary by only {variance:g} m² an "
                f"axis, not more than spin_variance ({self.episode.spin_variance:g} m²): every "
                "life could count as a spin; raise spin_window or lower spin_variance")
        return self

    @model_validator(mode="after")
    def _apart(self) -> Scenario:
        """Vehicles start where vehicles fit: no two starts nearer than a body's length."""
        starts = list(self.traffic.starts_xy)
        names = [f"traffic.starts_xy[{i}]" for i in range(len(starts))]
        if isinstance(self.track, TrackConfig) and self.track.start_xy is not None:
            starts, names = [self.track.start_xy, *starts], ["track.start_xy", *names]
        if len(starts) < 2:
            return self
        xy = np.asarray(starts)
        gaps = np.hypot(*(xy[:, None, :] - xy[None, :, :]).transpose(2, 0, 1))
        gaps[np.triu_indices(len(xy))] = np.inf
        near, far = np.unravel_index(np.argmin(gaps), gaps.shape)
        if gaps[near, far] < self.vehicle.length:
            raise ValueError(f"{names[near]}: {gaps[near, far]:g} m from {names[far]}; vehicles "
                             f"start at least the vehicle's length ({self.vehicle.length:g} m) "
                             "apart")
        return self

    @model_validator(mode="after")
    def _fringe_exits(self) -> Scenario:
        if (isinstance(self.track, TrackConfig) and self.track.fringe == "exit"
                and not self.traffic.is_sumo):
            raise ValueError('track.fringe: "exit" needs SUMO traffic (strategy = "sumo"); '
                             "scripted vehicles would drive off the map")
        return self

    @model_validator(mode="after")
    def _several_tracks(self) -> Scenario:
        if isinstance(self.track, TrackConfig) and self.track.traffic:
            raise ValueError("track.traffic: only with several tracks ([[track]]); with one, "
                             "these keys go in [traffic]")
        if self.track == []:
            raise ValueError("track: name at least one track")
        return self

    @property
    def tracks(self) -> list[TrackConfig]:
        """The tracks the learner drives: one, or each of ``[[track]]``."""
        if self.track is None:
            return []
        return [self.track] if isinstance(self.track, TrackConfig) else list(self.track)

    def on_track(self, index: int) -> Scenario:
        """The scenario on its ``index``-th track alone, with that track's ``[traffic]`` keys."""
        track = self.tracks[index]
        data = self.model_dump()
        data["track"] = {**track.model_dump(), "traffic": {}}
        data["traffic"] = {**data["traffic"], **track.traffic}
        return self._with_runtime(validated(data, self.source))

    def single_track(self, index: int | None = None) -> Scenario:
        """This scenario on one track, as an environment drives it: track ``index`` of a
        scenario of several, or its only one. A clear error when it has several and no
        ``index`` is given, or when ``index`` names no track."""
        count = len(self.tracks)
        if index is None:
            if count > 1:
                raise ValueError(f"{self.name}: an environment drives one track and this "
                                 f"scenario has {count}: pass track=0 … {count - 1}")
            return self.on_track(0) if isinstance(self.track, list) else self
        if not 0 <= index < max(count, 1):
            raise ValueError(f"{self.name}: track={index}, but the scenario has {count} "
                             f"track{'s' if count != 1 else ''}")
        return self.on_track(index) if isinstance(self.track, list) else self

    @property
    def fringe_exits(self) -> bool:
        """Does reaching the network's fringe end a life as "left the network" (the default
        with SUMO traffic) rather than count as a wall? (A single-track scenario's.)"""
        fringe = self.track.fringe if isinstance(self.track, TrackConfig) else None
        return fringe == "exit" or (fringe is None and self.traffic.is_sumo)

    @property
    def world_kind(self) -> str:
        """The kind of world it describes (a name of :data:`enn_traffic.sim.world.WORLDS`):
        several tracks side by side, a lane-keeping road, SUMO traffic, or the arena (arena and
        navigation tracks)."""
        if isinstance(self.track, list):
            return "tracks" if len(self.track) > 1 else self.on_track(0).world_kind
        if self.lane_keeping is not None:
            return "lane_keeping"
        return SUMO if self.traffic.is_sumo else "arena"

    @property
    def beams(self) -> list[tuple[float, float]]:
        """The rangefinder's beams, (angle relative to the heading in radians, range in
        metres), in the network's input order (:attr:`SensorConfig.beam_list`)."""
        return self.sensor.beam_list

    @property
    def beam_angles(self) -> list[float]:
        """Beam directions relative to the heading, radians, right (negative) to left."""
        return [angle for angle, _ in self.beams]

    @property
    def max_range(self) -> float:
        """The longest beam's range (m): nothing farther is sensed."""
        return max(reach for _, reach in self.beams)

    @property
    def layer_sizes(self) -> tuple[int, ...]:
        return (self.inputs, *self.network.hidden, 2)

    @property
    def traffic_layer_sizes(self) -> tuple[int, ...]:
        """The random-network traffic's layer sizes (``traffic.network_hidden``)."""
        return (self.inputs, *self.traffic.network_hidden, 2)

    @property
    def inputs(self) -> int:
        """Network inputs: one per beam and channel, or two marking offsets per look-ahead
        distance."""
        if self.lane_keeping is not None:
            return 2 * len(self.lane_keeping.lookahead_m)
        return self.sensor.readings

    def with_overrides(self, **sections: dict) -> Scenario:
        """A copy with some section fields replaced, validated again."""
        data = self.model_dump()
        for section, values in sections.items():
            if isinstance(values, dict):
                data[section] = {**data.get(section, {}), **values}
            else:
                data[section] = values
        return self._with_runtime(validated(data, self.source))

    def _with_runtime(self, other: Scenario) -> Scenario:
        """``other`` with this scenario's settings of the command that runs it."""
        return other.model_copy(update={"sumo_folder": self.sumo_folder,
                                        "sumo_console": self.sumo_console})

    def with_sumo_output(self, folder: Path | None, console: bool = False) -> Scenario:
        """A copy whose SUMO runs write their console log (and kept outputs) under
        ``folder``, or show SUMO's console instead (``console``)."""
        return self.model_copy(update={"sumo_folder": folder, "sumo_console": console})

    def check_population_fits(self) -> None:
        """A run's population fits memory: refused, naming ``ga.population_size``, beyond
        :data:`MAX_POPULATION_GENES`. Asked by a run of the resolved scenario (overrides such
        as ``--population`` applied), not at loading: evaluating a large network needs no
        population."""
        genes = NetworkSpec(self.layer_sizes).chromosome_length
        if self.ga.population_size * genes > MAX_POPULATION_GENES:
            raise InputError(
                f"{self.ga.population_size:,} chromosomes of {genes:,} genes "
                f"(network {list(self.layer_sizes)}) are {self.ga.population_size * genes:,} "
                f"genes, more than the {MAX_POPULATION_GENES:,} ("
                f"{MAX_POPULATION_GENES * 8 / 2**30:.1f} GiB) a population may hold; use a "
                "smaller network or population", self.source, "ga.population_size")

    def to_toml(self) -> str:
        data = self.model_dump(mode="json", exclude_none=True)
        for track in data["track"] if isinstance(data.get("track"), list) else []:
            if not track["traffic"]:
                del track["traffic"]
        key = _not_utf8(data)
        if key is not None:  # a name of bytes that are not UTF-8 (Linux allows them)
            raise InputError("names a file in a folder whose name is not UTF-8 text, which a "
                             "TOML file (a run's scenario.toml) cannot hold: rename the folder",
                             self.source, key)
        return tomli_w.dumps(data)


def _not_utf8(value, key: str = "") -> str | None:
    """The dotted key (``track.net``, ``traffic.routes[0]``) of the first string under
    ``value`` that UTF-8 cannot encode (a path's undecodable bytes, as Python keeps them),
    or None."""
    if isinstance(value, str):
        try:
            value.encode("utf-8")
        except UnicodeEncodeError:
            return key
        return None
    items = (value.items() if isinstance(value, dict)
             else enumerate(value) if isinstance(value, list) else ())
    for name, item in items:
        inner = f"{key}[{name}]" if isinstance(name, int) else f"{key}.{name}" if key else name
        found = _not_utf8(item, inner)
        if found is not None:
            return found
    return None


# pydantic's name of a union's member in an error's location (``literal['a','b']``,
# ``list[...]``): not a key of the file.
UNION_MEMBER = re.compile(r"[\w-]+\[.*\]")


def _key_of(error: dict) -> tuple[str, str]:
    """The key an error names, and its message. A check of several keys names its key as the
    message's prefix: ``"track.net: required ..."`` of the whole scenario, ``"learning_s:
    must be ..."`` of a section (the section's key then)."""
    parts = [part for part in error["loc"] if part not in ("one", "several")
             and not (isinstance(part, str) and UNION_MEMBER.fullmatch(part))]
    key = "".join(f"[{part}]" if isinstance(part, int) else f'."{part}"' if "." in part
                  else f".{part}" for part in parts)  # a quoted TOML key with a dot: one name
    key = key.removeprefix(".")
    message = error["msg"].removeprefix("Value error, ")
    prefix, _, rest = message.partition(": ")
    if rest and re.fullmatch(r"[a-z_]+(\[\d+\])?(\.[a-z_]+(\[\d+\])?)*", prefix):
        return f"{key}.{prefix}" if key else prefix, rest
    return key or "(top level)", message


QUOTED_DOT = " (a quoted key with a dot is one name; without the quotes each dot opens a table)"


def _deepest(errors: list[dict]) -> list[dict]:
    """The errors without those a deeper one explains: a list given where a value or a list
    may go fails both members of the union, and the one about its item says what is wrong
    (``traffic.strategy[0]``), not the one that wanted a single value."""
    keys = [_key_of(error)[0] for error in errors]
    above = {key[:cut] for key in keys  # every key that holds another (once per key: a
             for cut, char in enumerate(key) if char in ".["}  # file may hold very many)
    return [error for error, key in zip(errors, keys, strict=True) if key not in above] or errors


def validated(data: dict, source: Path | None) -> Scenario:
    quoted = [key for key in data if "." in key] if isinstance(data, dict) else []
    if quoted:  # said before the missing [track] it hides
        raise InputError("unknown key" + QUOTED_DOT, source, f'"{quoted[0]}"')
    tasks = [key for key in ("track", "lane_keeping")
             if isinstance(data, dict) and data.get(key) is not None]
    if isinstance(data, dict) and len(tasks) != 1:
        both = len(tasks) == 2
        raise InputError("give exactly one of [track] (a SUMO network) or [lane_keeping]"
                         if both else "required key is missing: [track] (a SUMO network) or "
                         "[lane_keeping]", source, "lane_keeping" if both else "track")
    try:
        scenario = Scenario.model_validate(data)
    except ValidationError as exc:
        errors = _deepest(exc.errors())
        first = errors[0]
        key, message = _key_of(first)
        if first["type"] == "extra_forbidden":
            message = "unknown key"
            if '"' in key:
                message += QUOTED_DOT
        elif first["type"] == "missing":
            message = "required key is missing"
        # a value that fits no member of a union is one problem, however many members
        others = len({_key_of(error)[0] for error in errors} - {key})
        extra = f" (and {others} more problems)" if others else ""
        raise InputError(message + extra, source, key) from None
    scenario = scenario.model_copy(update={"source": source})
    if isinstance(scenario.track, list):  # each track with its own traffic keys
        for index in range(len(scenario.track)):
            try:
                scenario.on_track(index)
            except InputError as exc:
                raise InputError(exc.message, source,
                                 track_key(exc.key, index, scenario.track[index])) from None
    return scenario


def track_key(key: str | None, index: int, track: TrackConfig) -> str:
    """The key of the scenario file that a single-track scenario's ``key`` came from: the
    ``index``-th ``[[track]]``, its ``[track.traffic]`` or the shared ``[traffic]``."""
    key = key or ""
    if key.startswith("track"):
        return f"track[{index}]{key.removeprefix('track')}"
    name = re.split(r"[.\[]", key.removeprefix("traffic."))[0]
    if (key.startswith("traffic.") and name in track.traffic) or (key == "traffic"
                                                                   and track.traffic):
        return f"track[{index}].{key}"
    return key or f"track[{index}]"
