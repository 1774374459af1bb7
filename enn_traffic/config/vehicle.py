"""``[vehicle]``: the kinematic bicycle at constant speed (paper §4)."""

from __future__ import annotations

from pydantic import Field, model_validator

from enn_traffic.config.base import PositiveFloat, Section


class VehicleConfig(Section):
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
