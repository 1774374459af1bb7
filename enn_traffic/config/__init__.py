"""Scenario files (TOML): schema, loading, and validation with clear errors.

A scenario names a SUMO network, the vehicle, its rangefinder, the controller network, the GA
settings and the episode rules. Degrees appear only here (keys ending in ``_deg``); everything
after loading is in metres, seconds and radians. See docs/scenarios.md.
"""

from __future__ import annotations

import functools
import hashlib
import importlib.util
import math
import re
import tomllib
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Annotated, Any, Literal

import numpy as np
import tomli_w
from pydantic import (
    BaseModel,
    ConfigDict,
    Discriminator,
    Field,
    Strict,
    Tag,
    ValidationError,
    field_validator,
    model_serializer,
    model_validator,
)

from enn_traffic.config.kinds import STRATEGIES, SUMO
from enn_traffic.core.cache import content_digest, file_stamp
from enn_traffic.core.errors import InputError
from enn_traffic.core.io import check_input_file
from enn_traffic.core.neural import NetworkSpec
from enn_traffic.roads.lanes import auto_lane
from enn_traffic.roads.network import least_start_length, read_net
from enn_traffic.roads.sumocfg import SumoConfig, check_included, read_sumocfg, with_includes

PositiveFloat = Annotated[float, Field(gt=0)]
Heading = Annotated[float, Field(ge=-360, le=360)]
Radius = Annotated[float, Field(gt=0, le=10_000)]
Length = Annotated[float, Field(gt=0, le=100_000)]
MAX_POPULATION_GENES = 50_000_000  # 0.4 GB a copy of the population; the GA holds a few
# learners in one SUMO: the largest count measured, each learner's own cost flat per learner
# there while SUMO's step grows with them (docs/bench.md, "Learners in one city SUMO")
MAX_LEARNERS = 1000
# Seeds are mixed into 64-bit keys (enn_traffic.core.keys): a larger one would wrap silently.
MAX_SEED = 2**63 - 1
# TOML has no tuples and no paths: these two take a list and a string (their items stay strict)
XY = Annotated[tuple[float, float], Strict(False)]
FilePath = Annotated[Path, Strict(False)]


class _Section(BaseModel):
    """Strict: a string or a boolean is never taken for a number (``beams = "19"`` is an
    error, not 19), nor a float for an integer; and no number is NaN or infinite."""

    model_config = ConfigDict(extra="forbid", frozen=True, strict=True, allow_inf_nan=False)


class TrackConfig(_Section):
    """Where the vehicle drives: a SUMO network and a start pose on it. ``start_lane`` and
    ``start_edge`` may list several, and ``start_anywhere`` takes every lane; each traffic
    situation then draws one."""

    net: FilePath | None = Field(
        None, description="SUMO `.net.xml`; the drivable area is the union of its lane and "
        "junction shapes, its boundary the walls (holes under 0.2 m wide excepted); may be left "
        "out when `traffic.sumocfg` names one. Any path may be `pkg:PACKAGE/path` (a file inside "
        "an installed Python package)")
    start_xy: XY | None = Field(
        None, description="start position of the front-bumper point; give one of `start_xy`, "
        "`start_lane`, `start_edge`")
    start_heading_deg: float = Field(
        0.0, ge=-360, le=360, description="start heading with `start_xy` (0 = +x, "
        "counter-clockwise; -360 to 360)")
    start_lane: str | list[str] | None = Field(
        None, description="start on this lane's centre line, `start_offset` m from its beginning, "
        "facing along it; the lane must allow passenger cars. A list: each traffic situation "
        "draws one. `\"auto\"`: the lane the traffic demand uses most (`enn-traffic lanes` "
        "ranks them), at least `start_offset` + 10 m + the vehicle's length long")
    start_edge: str | list[str] | None = Field(
        None, description="start on this edge's rightmost lane that allows passenger cars. A list: "
        "each traffic situation draws one")
    start_anywhere: bool = Field(
        False, description="`true`: each traffic situation starts at a spot drawn from the whole "
        "track: every 5 m along every passenger lane's centre line, facing either way, where the "
        "vehicle's body has 1 m to the walls and 10 m free ahead (instead of `start_xy`, "
        "`start_lane`, `start_edge`)")
    start_offset: float = Field(
        10.0, ge=0, le=100_000,
        description="distance of a lane or edge start from the "
        "lane's beginning (m)")
    surface: Literal["passenger", "all"] = Field(
        "passenger", description="the road surface, whose edges are walls: `passenger` (the lanes "
        "that allow passenger cars, and the junctions they meet less their walking areas: "
        "sidewalks, bike lanes, tram tracks and railways are not road) or `all` (every lane and "
        "junction of the network)")
    fringe: Literal["wall", "exit"] | None = Field(
        None, description="`exit`: nodes with a single neighbouring node (where traffic enters or "
        "leaves the map) are exits, and reaching one ends a life as `left network`, its steps "
        "counted as fitness; `wall`: they are walls. Default: `exit` with SUMO traffic, `wall` "
        "otherwise (the only choice there)")
    traffic: dict[str, Any] = Field(
        {}, description="with several tracks (`[[track]]`): the `[traffic]` keys that differ on "
        "this one (`[track.traffic]`: its `starts_xy`, `routes`, `sumocfg` ...), replacing the "
        "scenario's")

    @model_validator(mode="after")
    def _one_start(self) -> TrackConfig:
        given = [v for v in (self.start_xy, self.start_lane, self.start_edge) if v is not None]
        if len(given) + self.start_anywhere != 1:
            raise ValueError("give exactly one of start_xy (with start_heading_deg), start_lane, "
                             "start_edge or start_anywhere = true")
        for name in ("start_lane", "start_edge"):
            if getattr(self, name) == []:
                raise ValueError(f"{name}: must name at least one {name.removeprefix('start_')}")
        return self

    @property
    def start_names(self) -> list[tuple[str, str]]:
        """The start lanes and edges as (kind, id) pairs: ``("lane", id)`` or ``("edge", id)``;
        empty for ``start_xy`` and ``start_anywhere``."""
        for kind in ("lane", "edge"):
            value = getattr(self, f"start_{kind}")
            if value is not None:
                return [(kind, v) for v in ([value] if isinstance(value, str) else value)]
        return []


class VehicleConfig(_Section):
    """Kinematic bicycle, constant speed (paper §4; docs/design.md, "The authors' code" 2)."""

    length: PositiveFloat = Field(
        4.3, ge=0.5, le=30, description="body length (m, 0.5 to 30: a truck with its trailer); "
        "the pose is the middle of the front bumper")
    width: PositiveFloat = Field(1.7, ge=0.3, le=5, description="body width (m, 0.3 to 5)")
    wheelbase: PositiveFloat = Field(
        2.6, ge=0.2, le=30, description="wheelbase of the bicycle model (m, from 0.2 to the "
        "body's length)")
    speed: PositiveFloat = Field(10.0, ge=0.1, le=100, description="constant speed (m/s, 0.1 to "
                                 "100)")
    dt: float = Field(
        0.1, ge=0.001, le=1, description="time step (s, 0.001 to 1); with "
        "the default speed one step is 1 m. A step may not carry the vehicle farther than its "
        "own length (`speed` × `dt` ≤ `length`), so that it cannot jump a wall")

    @model_validator(mode="after")
    def _physical(self) -> VehicleConfig:
        if self.wheelbase > self.length:
            raise ValueError(f"wheelbase: {self.wheelbase:g} m must not exceed length "
                             f"({self.length:g} m)")
        if self.speed * self.dt > self.length:
            raise ValueError(f"speed: speed × dt = {self.speed * self.dt:g} m a step, farther "
                             f"than the body's length ({self.length:g} m): the vehicle could jump "
                             "a wall; lower speed or dt")
        return self


class RingConfig(_Section):
    """A further ring of rangefinder beams: ``beams`` equally spaced over ``span_deg`` around
    ``centre_deg``, right to left, each ``range`` long."""

    beams: int = Field(ge=1, le=361, description="beams of the ring")
    span_deg: float = Field(gt=0, le=360, description="horizontal span")
    range: PositiveFloat = Field(le=1000, description="beam length (m, at most 1000)")
    centre_deg: float = Field(
        0.0, ge=-180, le=180, description="direction of the ring's middle, "
        "relative to the heading: 0 ahead, 180 behind, positive to the left")


class SensorConfig(_Section):
    """Rangefinder: ``beams`` equally spaced over ``span_deg``, right to left (paper §3, §5.2),
    and any further ``rings``."""

    beams: int = Field(
        19, ge=1, le=361, description="rangefinder beams, equally spaced, right to left; 1 = "
        "straight ahead")
    span_deg: float = Field(
        180.0, gt=0, le=360, description="horizontal span of the beams")
    range: PositiveFloat = Field(
        25.0, le=1000, description="beam length (m, at most 1000); a beam that hits nothing "
        "reads the range")
    rings: list[RingConfig] = Field(
        [], max_length=8, description="further rings of beams (`[[sensor.rings]]`: `beams`, "
        "`span_deg`, `range`, `centre_deg`), say a short fan behind; the network reads the "
        "beams above, then each ring's, right to left")

    @model_serializer(mode="wrap")
    def _without_empty_rings(self, handler):
        """Leave ``rings`` out when there are none: a scenario written before rings existed
        keeps its settings' text (its ``scenario.toml``, which ``--resume`` compares, and the
        name of its run folder in a study, experiments/study.py)."""
        data = handler(self)
        if not self.rings:
            data.pop("rings", None)
        return data

    @property
    def beam_list(self) -> list[tuple[float, float]]:
        """Every beam as (angle relative to the heading in radians, range in metres): the
        first ring's, then each further ring's, right to left within a ring."""
        rings = [(self.beams, self.span_deg, self.range, 0.0)]
        rings += [(ring.beams, ring.span_deg, ring.range, ring.centre_deg) for ring in self.rings]
        return [(angle, reach) for count, span, reach, centre in rings
                for angle in fan(count, math.radians(span), math.radians(centre))]


def fan(count: int, span: float, centre: float = 0.0) -> list[float]:
    """``count`` beam angles (radians) equally spaced over ``span`` around ``centre``, right
    (negative) to left; one beam points at the centre."""
    if count == 1:
        return [centre]
    return [centre + (-span / 2 + span * i / (count - 1)) for i in range(count)]


class NetworkConfig(_Section):
    """Fully connected sigmoid network; 2 outputs (right, left steering force)."""

    hidden: list[Annotated[int, Field(ge=1, le=1024)]] = Field(
        [3], max_length=16, description="hidden layer sizes (up to 16 layers of up to 1024; [] = "
        "inputs straight to outputs); inputs = beams, outputs = 2 (right, left force), sigmoid "
        "everywhere")
    steering_gain_deg: float = Field(
        90.0, gt=0, le=180, description="steering = gain × (left − right)")
    layout: Literal["source", "target"] = Field(
        "source", description="chromosome layout: `source` (paper Fig. 1: weights out of one "
        "neuron consecutive, bias last) or `target` (the authors' MATLAB grouping)")


class GAConfig(_Section):
    """The paper's GA (§5) and its options; ``target_fitness`` stops a run early once a
    generation's best fitness reaches it."""

    population_size: int = Field(200, ge=2, le=100_000, description="chromosomes per generation")
    generations: int = Field(50, ge=1, le=100_000, description="generations to run")
    tournament_size: int = Field(
        10, ge=1, description="tournament selection, contestants drawn with replacement "
        "(left out: 10, or `population_size` when that is smaller)")
    crossover_probability: float = Field(
        1.0, ge=0, le=1, description="one-point crossover probability")
    crossover_cut_mean: float = Field(
        0.95, ge=0, le=1, description="the cut is at round(Normal(mean, std) × length)")
    crossover_cut_std: float = Field(
        0.05, ge=0, le=1, description="spread of the cut, as a share of the length")
    mutation_probability: float = Field(
        0.1, ge=0, le=1, description="per gene; a mutated gene is replaced by U[−init_range, "
        "init_range]")
    init_range: PositiveFloat = Field(
        1.0, le=1000, description="initial genes U[−init_range, init_range] (at most 1000)")
    elite_count: int = Field(
        0, ge=0, description="best chromosomes copied unchanged (0 = children replace parents, as "
        "in the paper)")
    target_fitness: float | None = Field(
        None, gt=0, description="stop early once a generation's best fitness "
        "reaches this")

    @model_validator(mode="before")
    @classmethod
    def _default_tournament(cls, data):
        """A tournament left out fits any population: 10, or the whole population."""
        if isinstance(data, dict) and "tournament_size" not in data:
            size = data.get("population_size", cls.model_fields["population_size"].default)
            if isinstance(size, int) and not isinstance(size, bool) and size >= 1:
                data = {**data, "tournament_size": min(size, 10)}
        return data

    @model_validator(mode="after")
    def _fits_population(self) -> GAConfig:
        if self.elite_count >= self.population_size:
            raise ValueError("elite_count: must be smaller than population_size")
        if self.tournament_size > self.population_size:
            raise ValueError("tournament_size: must not exceed population_size")
        return self


class EpisodeConfig(_Section):
    """Episode rules: step cap and the spin ("rotating around itself") penalty of §5.3."""

    max_steps: int = Field(20_000, ge=1, le=10_000_000, description="step cap of one life")
    spin_window: int = Field(
        49, ge=2, le=100_000,
        description="a vehicle whose last `spin_window` positions have variance ≤ "
        "`spin_variance` m² on both axes is spinning in place: fitness 0 (paper §5.3)")
    spin_variance: float = Field(
        64.0, ge=0, description="see `spin_window` (m²)")


# the arena's strategies (config.kinds.STRATEGIES; "none" is no traffic, not a choice) or SUMO
Strategy = Literal[(*(name for name in STRATEGIES if name != "none"), SUMO)]
CarFollowing = Literal["Krauss", "KraussPS", "KraussOrig1", "IDM", "EIDM", "IDMM", "ACC", "CACC",
                       "W99", "Wiedemann", "SmartSK", "PWagner2009", "BKerner"]


class DriversConfig(_Section):
    """How SUMO's drivers drive, in SUMO's own driver models (docs/sumo.md, "Driver models"):
    set on every traffic vehicle type (a vehicle type's own values are replaced; the learners
    are not traffic). Unset keys leave the scenario's files as they are."""

    car_following: CarFollowing | None = Field(
        None, description="car-following model of the vehicle types that name none (SUMO's "
        "`--default.carfollowmodel`; SUMO's own default is `Krauss`)")
    imperfection: float | None = Field(
        None, ge=0, le=1, description="driver imperfection `sigma` of the Krauss-family models "
        "(SUMO's default 0.5): random dawdling, 0 = perfect driving")
    tau_s: PositiveFloat | None = Field(
        None, le=100, description="desired time headway `tau` (s, at most 100; SUMO's default 1)")
    accel: PositiveFloat | None = Field(
        None, le=50, description="acceleration ability (m/s², at most 50)")
    decel: PositiveFloat | None = Field(
        None, le=50, description="comfortable deceleration (m/s², at most 50)")
    speed_factor: PositiveFloat | None = Field(
        None, le=10, description="mean factor on the lanes' speed limits that drivers aim at "
        "(at most 10)")
    lc_speed_gain: float | None = Field(
        None, ge=0, le=100, description="lane-change eagerness for speed "
        "(`lcSpeedGain`, default 1, at most 100); set on each vehicle as it departs")
    lc_cooperative: float | None = Field(
        None, ge=0, le=1, description="willingness to change lanes to let others in "
        "(`lcCooperative`, default 1)")
    lc_assertive: PositiveFloat | None = Field(
        None, le=100, description="acceptance of small gaps when changing lanes (`lcAssertive`, "
        "default 1, at most 100)")
    lc_keep_right: float | None = Field(
        None, ge=0, le=100, description="eagerness to keep to the right "
        "lane (`lcKeepRight`, default 1, at most 100)")
    demand_scale: PositiveFloat | None = Field(
        None, le=100, description="demand scaled by this factor (SUMO's `--scale`, at most "
        "100): 2 = twice the vehicles")

    def lane_change(self) -> dict[str, str]:
        """The lane-change parameters set, as SUMO's vehicle parameters
        (``laneChangeModel.lcSpeedGain`` ...) with their values."""
        names = {"lc_speed_gain": "lcSpeedGain", "lc_cooperative": "lcCooperative",
                 "lc_assertive": "lcAssertive", "lc_keep_right": "lcKeepRight"}
        return {f"laneChangeModel.{sumo}": f"{getattr(self, key):g}"
                for key, sumo in names.items() if getattr(self, key) is not None}



class TrafficConfig(_Section):
    """Uncontrolled vehicles around the learner (paper §5.3): one vehicle per start, all
    driving by ``strategy`` (a list: the fitness averages over the strategies, §5.4.1), or
    SUMO traffic from ``routes`` / ``sumocfg`` (strategy ``"sumo"``, docs/sumo.md)."""

    strategy: Strategy | Annotated[list[Strategy], Field(min_length=1)] = Field(
        "random_network", description="how the uncontrolled vehicles drive: `random_network`, "
        "`straight`, `circling`, `wander` (below) or `sumo`; a list = fitness averaged over those "
        "strategies")
    starts_xy: list[XY] = Field(
        [], max_length=1000, description="one uncontrolled vehicle per `[x, y]` start (at most "
        "1000, each at least the vehicle's length from every other and from the learner's "
        "`start_xy`); none = the learner drives alone")
    start_heading_deg: Annotated[tuple[Heading, Heading], Strict(False)] = Field(
        (-90.0, 90.0), description="their start headings are drawn from this range")
    seed: int = Field(1000, ge=0, le=MAX_SEED, description="traffic seed")
    network_hidden: list[Annotated[int, Field(ge=1, le=1024)]] = Field(
        [3], max_length=16,
        description="`random_network`: hidden layer sizes of the traffic's random networks "
        "(the paper's 19-3-2 traffic), whatever the learner's; the learner needs as many hidden "
        "layers, each at least as large")
    vary: Literal["generation", "fixed"] = Field(
        "generation", description="`generation` draws new traffic every generation (the same for "
        "every chromosome of it), `fixed` keeps one")
    episodes: int = Field(
        1, ge=1, le=1000, description="traffic situations per chromosome and strategy; fitness is "
        "the mean")
    turn_distance: float = Field(
        10.0, ge=0, le=1000,
        description="`straight`, `circling`, `wander`: turn when "
        "a wall is nearer than this (m) within ±`turn_cone_deg` ahead, until that cone is clear; "
        "0 = never turn")
    turn_steering_deg: float = Field(
        35.0, gt=0, le=90, description="the steering angle of those turns")
    turn_cone_deg: float = Field(
        20.0, ge=0, le=90, description="half-width of the cone ahead that "
        "starts a turn")
    wander_sigma_deg: float = Field(
        6.0, ge=0, le=90, description="`wander`: steering ← decay × steering "
        "+ Normal(0, σ), clipped to ±`wander_max_deg`")
    wander_decay: float = Field(0.95, ge=0, le=1, description="`wander`: the decay of that process")
    wander_max_deg: float = Field(
        45.0, gt=0, le=90, description="`wander`: the largest steering angle")
    circle_radius: Annotated[tuple[Radius, Radius], Strict(False)] = Field(
        (10.0, 30.0), description="`circling`: range of the circle radii (m), one drawn per life")
    respawn_clearance: float = Field(
        10.0, ge=0, le=1000,
        description="an uncontrolled vehicle that causes a "
        "collision respawns at a random free spot at least this far (m) from every other vehicle; "
        "with SUMO traffic, vehicles this near the learner's start leave its world before the "
        "first step")
    turn_side: Literal["open", "left", "right"] = Field(
        "open", description="which way the turns go: `open` (towards the side with more room), "
        "`left` or `right` (always; a one-way flow round the walls)")
    sees_vehicles: bool = Field(
        False, description="`straight`, `circling`, `wander`: also turn away from vehicles, not "
        "only walls, in the cone ahead")
    routes: list[FilePath] = Field(
        [], description="`strategy = \"sumo\"`: SUMO route files (routes, flows, vehicle types) "
        "run on the track's network")
    sumocfg: FilePath | None = Field(
        None, description="`strategy = \"sumo\"`: alternatively (or as well: `routes` are added to "
        "its route files) a SUMO `.sumocfg`, run as SUMO runs it — its begin and end, route and "
        "additional files; `[track] net`, when given, replaces its `net-file`")
    learners: int = Field(
        8, ge=1, le=MAX_LEARNERS, description="`strategy = \"sumo\"`: learners that drive at "
        "once in one SUMO, every vehicle a learner (Tables 3–4, paper §5.5; `enn-traffic "
        "crowd`); at most 1,000 in one SUMO, [bench.md](bench.md#learners-in-one-city-sumo) "
        "(more: `crowd --executor ray` runs the situations side by side)")
    mode: Literal["replay", "closed-loop"] = Field(
        "replay", description="SUMO traffic: `replay` (SUMO runs once per traffic situation "
        "without the learner; every chromosome meets the recording) or `closed-loop` (the learner "
        "is in SUMO every step and drivers react; slower)")
    begin_s: float | None = Field(
        None, ge=0, le=10_000_000, description="SUMO time at which traffic "
        "begins (s): the "
        "`.sumocfg`'s begin by default (0 without one)")
    warmup_s: float = Field(
        60.0, ge=0, le=86_400, description="SUMO time simulated after the "
        "begin before the learner starts; a life also ends at the `.sumocfg`'s end")
    drivers: DriversConfig = Field(
        DriversConfig(), description="`strategy = \"sumo\"`: SUMO's driver models and demand "
        "([sumo.md](sumo.md#driver-models)); the keys are listed under `[traffic.drivers]`")
    sumo_outputs: Literal["off", "keep"] = Field(
        "off", description="what SUMO writes by the scenario's `.sumocfg` and additional files "
        "(tripinfo, detectors, meandata, SSM, logs): `off` (written into a temporary folder of "
        "each SUMO start and deleted) or `keep` (kept in the run folder's `sumo/outputs/`, a "
        "folder per SUMO start). Never into the scenario's own folder "
        "([sumo.md](sumo.md#what-is-written-where))")
    outputs: list[Literal["tripinfo", "fcd", "ssm"]] = Field(
        [], description="SUMO's own outputs of every vehicle, without writing a `.sumocfg`: "
        "`tripinfo` (each trip's times, delays and route length, unfinished ones too), "
        "`fcd` (every vehicle's "
        "position and speed each step: large), `ssm` (every vehicle's conflicts: TTC, DRAC, "
        "PET, the learners' among them); each SUMO start writes them into the run folder's "
        "`sumo/outputs/` (a folder per start, as with `sumo_outputs = \"keep\"`, which they "
        "imply) ([sumo.md](sumo.md#what-is-written-where))")
    warmup_states: int = Field(
        0, ge=0, le=1000, description="`N` > 0: `N` warm-ups, simulated once and saved as SUMO "
        "states, shared by every traffic situation (each then drives on with its own seed); `0`: "
        "each situation warms up with its own seed ([sumo.md](sumo.md#warm-up-once))")

    @model_validator(mode="after")
    def _sumo_sources(self) -> TrafficConfig:
        names = [self.strategy] if isinstance(self.strategy, str) else self.strategy
        if "sumo" in names:
            if names != ["sumo"]:
                raise ValueError('"sumo" cannot be mixed with other strategies in one scenario')
            if self.starts_xy:
                raise ValueError('strategy "sumo" takes its vehicles from SUMO; '
                                 "leave starts_xy empty")
        elif self.routes or self.sumocfg is not None:
            raise ValueError('routes and sumocfg are for strategy = "sumo"')
        elif self.drivers != DriversConfig():
            raise ValueError('[traffic.drivers] is for strategy = "sumo"')
        return self

    @property
    def is_sumo(self) -> bool:
        return self.strategy == "sumo"

    @model_validator(mode="after")
    def _ordered_ranges(self) -> TrafficConfig:
        if self.circle_radius[0] > self.circle_radius[1]:
            raise ValueError("circle_radius: must be [smallest, largest]")
        if self.start_heading_deg[0] > self.start_heading_deg[1]:
            raise ValueError("start_heading_deg: must be [lowest, highest]")
        return self

    @property
    def strategy_list(self) -> list[str]:
        """The strategies to average over; ``["none"]`` when there are no vehicles."""
        if self.is_sumo:
            return ["sumo"]
        if not self.starts_xy:
            return ["none"]
        return [self.strategy] if isinstance(self.strategy, str) else list(self.strategy)


class CrowdConfig(_Section):
    """Every vehicle driving by its own network at once (paper §5.5, Tables 3–4): how its
    collisions are counted."""

    counting: Literal["responsible", "authors"] = Field(
        "responsible", description="the rates of Tables 3–4: `responsible` (responsible "
        "collisions per vehicle-second) or `authors` (lives lost, responsible collisions and "
        "spins, of all vehicles together per second: the authors' display's count, the "
        "paper's unit, [results.md](results.md#all-vehicles-at-once-paper-55-tables-34)). "
        "Read by `reproduce`'s crowds (`table3`, `table4`, `sumo`, `city`) from the shipped "
        "arena and SUMO scenarios, and by `enn-traffic crowd`; `run` says it ignores it")
    learning_s: float = Field(
        1000.0, gt=0, le=100_000, description="`enn-traffic crowd`: SUMO seconds every vehicle "
        "learns together (Table 4), a multiple of `window_s`")
    window_s: float = Field(
        100.0, gt=0, le=10_000, description="`enn-traffic crowd`: the span each rate is "
        "measured over (Table 3 the first, Table 4 the one after learning) and the learning "
        "curve's step (SUMO seconds)")
    life_cap_steps: int = Field(
        150, ge=0, le=1_000_000, description="`enn-traffic crowd`: a life that reaches this "
        "many steps ends its chromosome's trial without a respawn (0: no cap)")
    population_size: int = Field(
        20, ge=2, le=100_000, description="`enn-traffic crowd`: rows of the evolved population "
        "(the individual run's last, its elites first) each vehicle copies and evolves; at "
        "most `ga.population_size`")
    elite_count: int = Field(
        4, ge=0, le=100_000, description="`enn-traffic crowd`: the best chromosomes of all "
        "vehicles, the elites of each vehicle's next generation")
    situations: int = Field(
        10, ge=1, le=10_000, description="`enn-traffic crowd`: traffic situations measured (the "
        "crowd test keys), each arm paired by situation")
    validation_situations: int = Field(
        2, ge=0, le=1_000, description="`enn-traffic crowd`: validation situations whose "
        "learners' counts are written (`table4_validation_learners.csv`: do they breed?)")

    @model_validator(mode="after")
    def _whole_windows(self) -> CrowdConfig:
        windows = self.learning_s / self.window_s
        if abs(windows - round(windows)) > 1e-9:
            raise ValueError(f"learning_s: {self.learning_s:g} must be a multiple of "
                             f"window_s ({self.window_s:g})")
        if self.elite_count >= self.population_size:
            raise ValueError(f"elite_count: {self.elite_count} must be less than "
                             f"population_size ({self.population_size})")
        return self


Range = Annotated[tuple[Length, Length], Strict(False)]


class RoadDraw(_Section):
    """Lane keeping on roads drawn per traffic situation (each situation of each generation
    its own road): the road's shape, size and turning direction drawn uniformly."""

    roads: list[Literal["sine", "circle"]] = Field(
        ["sine", "circle"], min_length=1, description="the road shapes drawn from")
    amplitude: Range = Field((2.0, 7.0), description="sine roads: range of the amplitude (m)")
    period: Range = Field((60.0, 160.0), description="sine roads: range of the period (m)")
    radius: Range = Field((35.0, 90.0), description="circle roads: range of the radius (m)")
    both_directions: bool = Field(
        True, description="mirror half the roads (drawn), so that they turn the other way")

    @model_validator(mode="after")
    def _ordered(self) -> RoadDraw:
        for name in ("amplitude", "period", "radius"):
            low, high = getattr(self, name)
            if low > high:
                raise ValueError(f"{name}: must be [smallest, largest]")
        return self


class LaneKeepingConfig(_Section):
    """Lane keeping on a highway-env road, steered from a camera's lane markings (paper §5.6):
    the lateral offsets of both markings at each look-ahead distance, in the vehicle frame."""

    road: Literal["sine", "circle"] = Field(
        "sine", description="`sine` (highway-env's lane-keeping road shape) or `circle`")
    amplitude: float = Field(
        5.0, ge=0, le=1000,
        description="sine road: amplitude of the centre line (m)")
    period: float = Field(
        100.0, ge=10, le=100_000, description="sine road: period of the centre line (m, 10 to "
        "100,000)")
    length: float = Field(1000.0, ge=10, le=100_000, description="sine road: length (m)")
    radius: float = Field(
        60.0, ge=5, le=100_000, description="circle road: radius of the centre line (m, 5 to "
        "100,000)")
    mirrored: bool = Field(
        False, description="the road mirrored: its bends turn the other way (a circle driven "
        "anticlockwise)")
    lane_width: float = Field(
        4.0, ge=1, le=20,
        description="lane width (m); the life ends when the vehicle's centre leaves the lane")
    lookahead_m: list[Annotated[float, Field(gt=0, le=1000)]] = Field(
        [5.0, 10.0, 15.0, 20.0], min_length=1, max_length=32, description="the camera's "
        "look-ahead distances along the lane (up to 32, each at most 1000 m); the network gets "
        "both markings' lateral offsets (vehicle frame) at each: 2 inputs per distance")
    noise_m: float = Field(
        0.0, ge=0, le=100, description="Gaussian noise on the offsets (m)")
    episodes: int = Field(1, ge=1, le=1000, description="episodes per chromosome")
    seed: int = Field(0, ge=0, le=MAX_SEED, description="noise and road-drawing seed")
    draw: RoadDraw | None = Field(
        None, description="`[lane_keeping.draw]`: each traffic situation draws its `road`, "
        "`amplitude`, `period`, `radius` and `mirrored` (those keys above are then unused); "
        "none = always the road above")


class Scenario(_Section):
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
    def _fits_memory(self) -> Scenario:
        genes = NetworkSpec(self.layer_sizes).chromosome_length
        if self.ga.population_size * genes > MAX_POPULATION_GENES:
            raise ValueError(
                f"ga.population_size: {self.ga.population_size:,} chromosomes of {genes:,} genes "
                f"(network {list(self.layer_sizes)}) are {self.ga.population_size * genes:,} "
                f"genes, more than the {MAX_POPULATION_GENES:,} ("
                f"{MAX_POPULATION_GENES * 8 / 2**30:.1f} GiB) a population may hold; use a "
                "smaller network or population")
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
        return self._with_runtime(_validate(data, self.source))

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
        """Network inputs: one per beam, or two marking offsets per look-ahead distance."""
        if self.lane_keeping is not None:
            return 2 * len(self.lane_keeping.lookahead_m)
        return len(self.beams)

    def with_overrides(self, **sections: dict) -> Scenario:
        """A copy with some section fields replaced, validated again."""
        data = self.model_dump()
        for section, values in sections.items():
            if isinstance(values, dict):
                data[section] = {**data.get(section, {}), **values}
            else:
                data[section] = values
        return self._with_runtime(_validate(data, self.source))

    def _with_runtime(self, other: Scenario) -> Scenario:
        """``other`` with this scenario's settings of the command that runs it."""
        return other.model_copy(update={"sumo_folder": self.sumo_folder,
                                        "sumo_console": self.sumo_console})

    def with_sumo_output(self, folder: Path | None, console: bool = False) -> Scenario:
        """A copy whose SUMO runs write their console log (and kept outputs) under
        ``folder``, or show SUMO's console instead (``console``)."""
        return self.model_copy(update={"sumo_folder": folder, "sumo_console": console})

    def to_toml(self) -> str:
        data = self.model_dump(mode="json", exclude_none=True)
        for track in data["track"] if isinstance(data.get("track"), list) else []:
            if not track["traffic"]:
                del track["traffic"]
        return tomli_w.dumps(data)


def _key_of(error: dict) -> tuple[str, str]:
    """The key an error names, and its message. A check of several keys names its key as the
    message's prefix: ``"track.net: required ..."`` of the whole scenario, ``"learning_s:
    must be ..."`` of a section (the section's key then)."""
    parts = [part for part in error["loc"] if part not in ("one", "several")]
    key = "".join(f"[{part}]" if isinstance(part, int) else f'."{part}"' if "." in part
                  else f".{part}" for part in parts)  # a quoted TOML key with a dot: one name
    key = key.removeprefix(".")
    message = error["msg"].removeprefix("Value error, ")
    prefix, _, rest = message.partition(": ")
    if rest and re.fullmatch(r"[a-z_]+(\[\d+\])?(\.[a-z_]+(\[\d+\])?)*", prefix):
        return f"{key}.{prefix}" if key else prefix, rest
    return key or "(top level)", message


QUOTED_DOT = " (a quoted key with a dot is one name; without the quotes each dot opens a table)"


def _validate(data: dict, source: Path | None) -> Scenario:
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
        first = exc.errors()[0]
        key, message = _key_of(first)
        if first["type"] == "extra_forbidden":
            message = "unknown key"
            if '"' in key:
                message += QUOTED_DOT
        elif first["type"] == "missing":
            message = "required key is missing"
        extra = f" (and {exc.error_count() - 1} more problems)" if exc.error_count() > 1 else ""
        raise InputError(message + extra, source, key) from None
    scenario = scenario.model_copy(update={"source": source})
    if isinstance(scenario.track, list):  # each track with its own traffic keys
        for index in range(len(scenario.track)):
            try:
                scenario.on_track(index)
            except InputError as exc:
                raise InputError(exc.message, source,
                                 _in_track(exc.key, index, scenario.track[index])) from None
    return scenario


def _in_track(key: str | None, index: int, track: TrackConfig) -> str:
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
        text = path.read_text()
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
    scenario = _validate(data, path.resolve())
    if not isinstance(scenario.track, list):
        return _with_files(scenario, path)
    tracks = []
    for index in range(len(scenario.track)):
        try:
            tracks.append(_with_files(scenario.on_track(index), path).track)
        except InputError as exc:
            raise InputError(exc.message, path,
                             _in_track(exc.key, index, scenario.track[index])) from None
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
    length = least_start_length(track.start_offset, scenario.vehicle.length)
    config = sumo_config(scenario)
    additional = config.additional_files if config is not None else ()
    with network_named(scenario):
        read_net(track.net)  # read once per process: auto_lane reads it from memory
    try:
        lane = auto_lane(track.net, route_files(scenario), length, additional)
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


def sumo_sources(path: Path) -> tuple[Path, list[Path], list[Path], float]:
    """The network, route files and additional files of a ``.sumocfg``, or of a scenario of
    one track (its SUMO traffic's; no route files without SUMO traffic), and the shortest lane
    its learner may start on (:func:`~enn_traffic.roads.network.least_start_length`; a
    ``.sumocfg``'s: by the default ``start_offset`` and body)."""
    if path.suffix == ".sumocfg":
        if not path.is_file():
            raise InputError("SUMO configuration not found", path)
        config = read_sumocfg(path)
        if config.net_file is None:
            raise InputError("names no net-file", path, "net-file")
        shortest = least_start_length(TrackConfig.model_fields["start_offset"].default,
                                      VehicleConfig.model_fields["length"].default)
        return (config.net_file, list(config.route_files), list(config.additional_files),
                shortest)
    scenario = load_scenario(path)
    if isinstance(scenario.track, list):
        raise InputError("give a scenario of one track (or its .sumocfg)", path, "track")
    if scenario.track is None:
        raise InputError("a lane-keeping scenario has no SUMO network", path, "lane_keeping")
    config = sumo_config(scenario)
    return (scenario.track.net, route_files(scenario) if scenario.traffic.is_sumo else [],
            list(config.additional_files) if config is not None else [],
            least_start_length(scenario.track.start_offset, scenario.vehicle.length))
