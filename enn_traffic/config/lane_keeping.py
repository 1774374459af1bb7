"""``[lane_keeping]``: a highway-env road and its camera (paper §5.6)."""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import Field, model_validator

from enn_traffic.config.base import MAX_SEED, Range, Section


class RoadDraw(Section):
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


class LaneKeepingConfig(Section):
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
