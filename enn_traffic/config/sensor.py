"""``[sensor]``: the rangefinder (paper §3, §5.2): its beams and any further rings of them."""

from __future__ import annotations

import math

from pydantic import Field, model_serializer

from enn_traffic.config.base import PositiveFloat, Section


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

    @model_serializer(mode="wrap")
    def _without_empty_rings(self, handler):
        """Leave ``rings`` out when there are none, so that a scenario of one fan of beams
        reads the same whether or not it names ``rings = []`` (its ``scenario.toml``, which
        ``--resume`` compares, and the name of its run folder in a study,
        experiments/study.py)."""
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
