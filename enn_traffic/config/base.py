"""What every section of a scenario file shares: strict validation, and the field types
and limits its keys use."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

from pydantic import BaseModel, ConfigDict, Field, Strict

PositiveFloat = Annotated[float, Field(gt=0)]
Heading = Annotated[float, Field(ge=-360, le=360)]
Radius = Annotated[float, Field(gt=0, le=10_000)]
Length = Annotated[float, Field(gt=0, le=100_000)]
# Learners in one SUMO: the largest count measured, each learner's own cost flat per learner
# there while SUMO's step grows with them (docs/bench.md, "Learners in one city SUMO")
MAX_LEARNERS = 3000
# Seeds are mixed into 64-bit keys (enn_traffic.core.keys): a larger one would wrap silently.
MAX_SEED = 2**63 - 1
# TOML has no tuples and no paths: these two take a list and a string (their items stay strict)
XY = Annotated[tuple[float, float], Strict(False)]
FilePath = Annotated[Path, Strict(False)]
Range = Annotated[tuple[Length, Length], Strict(False)]


class Section(BaseModel):
    """Strict: a string or a boolean is never taken for a number (``beams = "19"`` is an
    error, not 19), nor a float for an integer; and no number is NaN or infinite."""

    model_config = ConfigDict(extra="forbid", frozen=True, strict=True, allow_inf_nan=False)
