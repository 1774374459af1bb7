"""``[traffic]``: the uncontrolled vehicles around the learner (paper §5.3): the arena's
scripted strategies and their driver kinds, or SUMO's traffic and driver models."""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import Field, Strict, model_validator

from enn_traffic.config.base import (
    MAX_LEARNERS,
    MAX_SEED,
    XY,
    FilePath,
    Heading,
    PositiveFloat,
    Radius,
    Section,
)

# Who steers a vehicle in the compiled rules: nobody (it stands), a network (the learner's, an
# evolved driver's, or the random-network strategy's fixed random genes), a scripted strategy
# (paper §5.3, Figure 11), or an action given from outside the step (a gymnasium or PettingZoo
# environment's).
NONE, NETWORK, STRAIGHT, CIRCLING, WANDER, ACTION = range(6)

# The arena's traffic strategies (``[traffic] strategy``) and the driver kind of their vehicles;
# ``none`` is a scenario without traffic vehicles. A strategy's steering is a branch of
# enn_traffic.sim.strategies.scripted_steering.
STRATEGIES = {
    "none": NONE,
    "random_network": NETWORK,
    "straight": STRAIGHT,
    "circling": CIRCLING,
    "wander": WANDER,
}
SUMO = "sumo"  # ``strategy = "sumo"``: the vehicles come from SUMO (docs/sumo.md)
# the arena's strategies (config.traffic.STRATEGIES; "none" is no traffic, not a choice) or SUMO
Strategy = Literal[(*(name for name in STRATEGIES if name != "none"), SUMO)]
CarFollowing = Literal["Krauss", "KraussPS", "KraussOrig1", "IDM", "EIDM", "IDMM", "ACC", "CACC",
                       "W99", "Wiedemann", "SmartSK", "PWagner2009", "BKerner"]


class DriversConfig(Section):
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


class TrafficConfig(Section):
    """Uncontrolled vehicles around the learner (paper §5.3): one vehicle per start, all
    driving by ``strategy`` (a list: the fitness averages over the strategies, §5.4.1), or
    SUMO traffic from ``routes`` / ``sumocfg`` (strategy ``"sumo"``, docs/sumo.md)."""

    strategy: Strategy | Annotated[list[Strategy], Field(min_length=1)] = Field(
        "random_network", description="how the uncontrolled vehicles drive: "
        + ", ".join(f"`{name}`" for name in STRATEGIES if name != "none")
        + f" (below) or `{SUMO}`; a list = fitness averaged over those strategies")
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
        f"crowd`); at most {MAX_LEARNERS:,} in one SUMO, "
        "[bench.md](bench.md#learners-in-one-city-sumo) (more: `crowd --executor ray` runs "
        "the situations side by side)")
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
