"""Scenario files (TOML): schema, loading, and validation with clear errors.

A scenario names a SUMO network, the vehicle, its rangefinder, the controller network, the GA
settings and the episode rules. Degrees appear only here (keys ending in ``_deg``); everything
after loading is in metres, seconds and radians. See docs/scenarios.md.
"""

from __future__ import annotations

import importlib.util
import math
import re
import tomllib
from pathlib import Path
from typing import Annotated, Literal

import tomli_w
from pydantic import BaseModel, ConfigDict, Field, ValidationError, model_validator

from enn_traffic.errors import InputError

PositiveFloat = Annotated[float, Field(gt=0, allow_inf_nan=False)]


class _Section(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


class TrackConfig(_Section):
    """Where the vehicle drives: a SUMO network and a start pose on it. ``start_lane`` and
    ``start_edge`` may list several; each traffic situation then draws one."""

    net: Path | None = None
    start_xy: tuple[float, float] | None = None
    start_heading_deg: float = Field(0.0, allow_inf_nan=False)
    start_lane: str | list[str] | None = None
    start_edge: str | list[str] | None = None
    start_offset: float = Field(10.0, ge=0, allow_inf_nan=False)
    fringe: Literal["wall", "exit"] | None = None

    @model_validator(mode="after")
    def _one_start(self) -> TrackConfig:
        given = [v for v in (self.start_xy, self.start_lane, self.start_edge) if v is not None]
        if len(given) != 1:
            raise ValueError("give exactly one of start_xy (with start_heading_deg), start_lane "
                             "or start_edge")
        for name in ("start_lane", "start_edge"):
            if getattr(self, name) == []:
                raise ValueError(f"{name} must name at least one {name.removeprefix('start_')}")
        return self

    @property
    def start_names(self) -> list[tuple[str, str]]:
        """The start lanes and edges as (kind, id) pairs: ``("lane", id)`` or ``("edge", id)``;
        empty for ``start_xy``."""
        for kind in ("lane", "edge"):
            value = getattr(self, f"start_{kind}")
            if value is not None:
                return [(kind, v) for v in ([value] if isinstance(value, str) else value)]
        return []


class VehicleConfig(_Section):
    """Kinematic bicycle, constant speed (paper §4; docs/design.md, "The authors' code" 2)."""

    length: PositiveFloat = 4.3
    width: PositiveFloat = 1.7
    wheelbase: PositiveFloat = 2.6
    speed: PositiveFloat = 10.0
    dt: PositiveFloat = 0.1


class SensorConfig(_Section):
    """Rangefinder: ``beams`` equally spaced over ``span_deg``, right to left (paper §3, §5.2)."""

    beams: int = Field(19, ge=1, le=361)
    span_deg: float = Field(180.0, gt=0, le=360, allow_inf_nan=False)
    range: PositiveFloat = 25.0


class NetworkConfig(_Section):
    """Fully connected sigmoid network; 2 outputs (right, left steering force)."""

    hidden: list[Annotated[int, Field(ge=1, le=1024)]] = [3]
    steering_gain_deg: float = Field(90.0, gt=0, le=180, allow_inf_nan=False)
    layout: Literal["source", "target"] = "source"


class GAConfig(_Section):
    """The paper's GA (§5) and its options; ``target_fitness`` stops a run early once a
    generation's best fitness reaches it."""

    population_size: int = Field(200, ge=2, le=100_000)
    generations: int = Field(50, ge=1, le=100_000)
    tournament_size: int = Field(10, ge=1)
    crossover_probability: float = Field(1.0, ge=0, le=1)
    crossover_cut_mean: float = Field(0.95, ge=0, le=1)
    crossover_cut_std: float = Field(0.05, ge=0, le=1)
    mutation_probability: float = Field(0.1, ge=0, le=1)
    init_range: PositiveFloat = 1.0
    elite_count: int = Field(0, ge=0)
    target_fitness: float | None = Field(None, gt=0, allow_inf_nan=False)

    @model_validator(mode="after")
    def _fits_population(self) -> GAConfig:
        if self.elite_count >= self.population_size:
            raise ValueError("elite_count must be smaller than population_size")
        if self.tournament_size > self.population_size:
            raise ValueError("tournament_size must not exceed population_size")
        return self


class EpisodeConfig(_Section):
    """Episode rules: step cap and the spin ("rotating around itself") penalty of §5.3."""

    max_steps: int = Field(20_000, ge=1, le=10_000_000)
    spin_window: int = Field(49, ge=2)
    spin_variance: float = Field(64.0, ge=0, allow_inf_nan=False)


Strategy = Literal["random_network", "straight", "circling", "wander", "sumo"]


class TrafficConfig(_Section):
    """Uncontrolled vehicles around the learner (paper §5.3): one vehicle per start, all
    driving by ``strategy`` (a list: the fitness averages over the strategies, §5.4.1), or
    SUMO traffic from ``routes`` / ``sumocfg`` (strategy ``"sumo"``, docs/sumo.md)."""

    strategy: Strategy | list[Strategy] = "random_network"
    starts_xy: list[tuple[float, float]] = []
    start_heading_deg: tuple[float, float] = (-90.0, 90.0)
    seed: int = Field(1000, ge=0)
    vary: Literal["generation", "fixed"] = "generation"
    episodes: int = Field(1, ge=1, le=1000)
    turn_distance: float = Field(10.0, ge=0, allow_inf_nan=False)
    turn_steering_deg: float = Field(35.0, gt=0, le=90, allow_inf_nan=False)
    turn_cone_deg: float = Field(20.0, ge=0, le=90, allow_inf_nan=False)
    wander_sigma_deg: float = Field(6.0, ge=0, le=90, allow_inf_nan=False)
    wander_decay: float = Field(0.95, ge=0, le=1)
    wander_max_deg: float = Field(45.0, gt=0, le=90, allow_inf_nan=False)
    circle_radius: tuple[PositiveFloat, PositiveFloat] = (10.0, 30.0)
    respawn_clearance: float = Field(10.0, ge=0, allow_inf_nan=False)
    turn_side: Literal["open", "left", "right"] = "open"
    sees_vehicles: bool = False
    routes: list[Path] = []
    sumocfg: Path | None = None
    mode: Literal["replay", "closed-loop"] = "replay"
    begin_s: float | None = Field(None, ge=0, allow_inf_nan=False)
    warmup_s: float = Field(60.0, ge=0, le=86_400, allow_inf_nan=False)
    warmup_states: int = Field(0, ge=0, le=1000)

    @model_validator(mode="after")
    def _sumo_sources(self) -> TrafficConfig:
        names = [self.strategy] if isinstance(self.strategy, str) else self.strategy
        if "sumo" in names:
            if names != ["sumo"]:
                raise ValueError('"sumo" cannot be mixed with other strategies in one scenario')
            if not self.routes and self.sumocfg is None:
                raise ValueError('strategy "sumo" needs routes (route files) or a sumocfg')
            if self.starts_xy:
                raise ValueError('strategy "sumo" takes its vehicles from SUMO; '
                                 "leave starts_xy empty")
        elif self.routes or self.sumocfg is not None:
            raise ValueError('routes and sumocfg are for strategy = "sumo"')
        return self

    @property
    def is_sumo(self) -> bool:
        return self.strategy == "sumo"

    @model_validator(mode="after")
    def _ordered_ranges(self) -> TrafficConfig:
        if self.circle_radius[0] > self.circle_radius[1]:
            raise ValueError("circle_radius must be [smallest, largest]")
        if self.start_heading_deg[0] > self.start_heading_deg[1]:
            raise ValueError("start_heading_deg must be [lowest, highest]")
        return self

    @property
    def strategy_list(self) -> list[str]:
        """The strategies to average over; ``["none"]`` when there are no vehicles."""
        if self.is_sumo:
            return ["sumo"]
        if not self.starts_xy:
            return ["none"]
        return [self.strategy] if isinstance(self.strategy, str) else list(self.strategy)


class LaneKeepingConfig(_Section):
    """Lane keeping on a highway-env road, steered from a camera's lane markings (paper §5.6):
    the lateral offsets of both markings at each look-ahead distance, in the vehicle frame."""

    road: Literal["sine", "circle"] = "sine"
    amplitude: float = Field(5.0, ge=0, allow_inf_nan=False)
    period: PositiveFloat = 100.0
    length: PositiveFloat = 1000.0
    radius: PositiveFloat = 60.0
    lane_width: PositiveFloat = 4.0
    lookahead_m: list[PositiveFloat] = Field([5.0, 10.0, 15.0, 20.0], min_length=1)
    noise_m: float = Field(0.0, ge=0, allow_inf_nan=False)
    episodes: int = Field(1, ge=1, le=1000)
    seed: int = Field(0, ge=0)


class Scenario(_Section):
    """A whole scenario file: a SUMO ``[track]`` (navigation, arena, SUMO traffic) or a
    highway-env ``[lane_keeping]`` road."""

    name: str = Field(min_length=1, pattern=r"^[A-Za-z0-9_.-]+$")
    description: str = ""
    seed: int = Field(0, ge=0)
    track: TrackConfig | None = None
    lane_keeping: LaneKeepingConfig | None = None
    vehicle: VehicleConfig = VehicleConfig()
    sensor: SensorConfig = SensorConfig()
    network: NetworkConfig = NetworkConfig()
    ga: GAConfig = GAConfig()
    episode: EpisodeConfig = EpisodeConfig()
    traffic: TrafficConfig = TrafficConfig()
    source: Path | None = Field(None, exclude=True)

    @model_validator(mode="after")
    def _one_task(self) -> Scenario:
        if (self.track is None) == (self.lane_keeping is None):
            raise ValueError("give exactly one of [track] (a SUMO network) or [lane_keeping]")
        return self

    @model_validator(mode="after")
    def _track_net(self) -> Scenario:
        if self.track is not None and self.track.net is None and self.traffic.sumocfg is None:
            raise ValueError("track.net: required unless traffic.sumocfg names the network")
        return self

    @model_validator(mode="after")
    def _fringe_exits(self) -> Scenario:
        if self.track is not None and self.track.fringe == "exit" and not self.traffic.is_sumo:
            raise ValueError('track.fringe: "exit" needs SUMO traffic (strategy = "sumo"); '
                             "scripted vehicles would drive off the map")
        return self

    @property
    def fringe_exits(self) -> bool:
        """Does reaching the network's fringe end a life as "left the network" (the default
        with SUMO traffic) rather than count as a wall?"""
        fringe = self.track.fringe if self.track is not None else None
        return fringe == "exit" or (fringe is None and self.traffic.is_sumo)

    @property
    def beam_angles(self) -> list[float]:
        """Beam directions relative to the heading, radians, right (negative) to left."""
        n, span = self.sensor.beams, math.radians(self.sensor.span_deg)
        if n == 1:
            return [0.0]
        return [-span / 2 + span * i / (n - 1) for i in range(n)]

    @property
    def layer_sizes(self) -> tuple[int, ...]:
        return (self.inputs, *self.network.hidden, 2)

    @property
    def inputs(self) -> int:
        """Network inputs: one per beam, or two marking offsets per look-ahead distance."""
        if self.lane_keeping is not None:
            return 2 * len(self.lane_keeping.lookahead_m)
        return self.sensor.beams

    def with_overrides(self, **sections: dict) -> Scenario:
        """A copy with some section fields replaced, validated again."""
        data = self.model_dump()
        for section, values in sections.items():
            if isinstance(values, dict):
                data[section] = {**data.get(section, {}), **values}
            else:
                data[section] = values
        return _validate(data, self.source)

    def to_toml(self) -> str:
        data = self.model_dump(mode="json", exclude_none=True)
        return tomli_w.dumps(data)


def _key_of(error: dict) -> tuple[str, str]:
    """The key an error names, and its message. A whole-scenario check names its key as the
    message's prefix (``"track.net: required ..."``)."""
    key = ".".join(str(part) for part in error["loc"])
    message = error["msg"].removeprefix("Value error, ")
    prefix, _, rest = message.partition(": ")
    if not key and rest and re.fullmatch(r"[a-z_]+(\.[a-z_]+)*", prefix):
        return prefix, rest
    return key or "(top level)", error["msg"]


def _validate(data: dict, source: Path | None) -> Scenario:
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
        first = exc.errors()[0]
        key, message = _key_of(first)
        if first["type"] == "extra_forbidden":
            message = "unknown key"
        elif first["type"] == "missing":
            message = "required key is missing"
        extra = f" (and {exc.error_count() - 1} more problems)" if exc.error_count() > 1 else ""
        raise InputError(message + extra, source, key) from None
    return scenario.model_copy(update={"source": source})


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
        return str((path.parent / value).resolve())

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
    if not path.is_file():
        raise InputError("scenario file not found", path)
    try:
        data = tomllib.loads(path.read_text())
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise InputError(f"not valid TOML: {exc}", path) from None
    _resolve(path, data.get("track"), "net")
    _resolve(path, data.get("traffic"), "routes")
    _resolve(path, data.get("traffic"), "sumocfg")
    scenario = _validate(data, path.resolve())
    traffic = scenario.traffic
    for index, route in enumerate(traffic.routes):
        if not route.is_file():
            raise InputError(f"route file not found: {route}", path, f"traffic.routes[{index}]")
    if traffic.sumocfg is not None:
        if not traffic.sumocfg.is_file():
            raise InputError(f"SUMO configuration not found: {traffic.sumocfg}", path,
                             "traffic.sumocfg")
        scenario = _with_sumocfg(scenario, path)
    if scenario.track is not None and not scenario.track.net.is_file():
        raise InputError(f"network file not found: {scenario.track.net}", path, "track.net")
    return scenario


def _with_sumocfg(scenario: Scenario, path: Path) -> Scenario:
    """Check the ``.sumocfg`` and the learner's start time against its begin and end; fill
    ``[track] net`` from it when left out."""
    from enn_traffic.traffic.sumocfg import read_sumocfg

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
