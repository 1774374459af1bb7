"""``[sensor]``: the rangefinder (paper §3, §5.2): its beams and any further rings of them."""

from __future__ import annotations

import math
from typing import Literal

from pydantic import Field, field_validator, model_serializer

from enn_traffic.config.base import PositiveFloat, Section

# What a beam can read, each a channel of the network's inputs (enn_traffic.sim.sensors computes
# them): the distance to what it meets (the paper's), the speed at which that closes in.
CHANNELS = ("distance", "closing_speed")
Channel = Literal[CHANNELS]


class RingConfig(Section):
    """A further ring of rangefinder beams: ``beams`` equally spaced over ``span_deg`` around
    ``centre_deg``, right to left, each ``range`` long."""

    beams: int = Field(ge=1, le=361, description="beams of the ring")
    span_deg: float = Field(gt=0, le=360, description="horizontal span")
    range: PositiveFloat = Field(le=1000, description="beam length (m, at most 1000)")
    centre_deg: float = Field(
        0.0, ge=-180, le=180, description="direction of the ring's middle, "
        "relative to the heading: 0 ahead, 180 behind, positive to the left")


class SensorConfig(Section):
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

    channels: list[Channel] = Field(
        ["distance"], min_length=1, description="what each beam (the rings' too) reads: "
        "`distance` (m, the paper's) first, then any of `closing_speed` (m/s at which what "
        "the beam meets draws nearer along it: the vehicle's velocity along its heading less "
        "that body's over the last step, a wall's 0; negative when it draws away, 0 when it "
        "meets nothing; unbounded in an environment's observation space, so scale it there, "
        "`VecNormalize` for one); the network reads every beam's distance, then every beam's "
        "next channel, so its inputs are beams × channels. A controller keeps the channels "
        "it was evolved with, as it keeps its rings")

    @field_validator("channels")
    @classmethod
    def _distance_first(cls, channels: list[str]) -> list[str]:
        if channels[0] != "distance":
            raise ValueError("the first channel is `distance` (the scripted strategies read "
                             "it)")
        if len(set(channels)) < len(channels):
            raise ValueError("a channel is named twice")
        return channels

    @model_serializer(mode="wrap")
    def _without_defaults(self, handler):
        """Leave ``rings`` out when there are none and ``channels`` when the beams read
        distances only, so that a scenario of one fan of distances reads the same whether or
        not it names them (its ``scenario.toml``, which ``--resume`` compares, the name of its
        run folder in a study, experiments/study.py, and its digest)."""
        data = handler(self)
        if not self.rings:
            data.pop("rings", None)
        if self.channels == ["distance"]:
            data.pop("channels", None)
        return data

    @property
    def readings(self) -> int:
        """Readings the sensor gives each step: one per beam and channel."""
        return len(self.beam_list) * len(self.channels)

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
