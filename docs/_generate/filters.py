"""How the templates write numbers: one filter per way, so that a table's cells and the prose
beside it say a value alike."""

from __future__ import annotations

import math

from enn_traffic.experiments import EXPERIMENTS


def g(value: float) -> str:
    """Python's general format (``{:g}``): 0.5, 10, 1e+06."""
    return f"{value:g}"


def fixed(value: float, digits: int = 0) -> str:
    """``digits`` after the point."""
    return f"{value:.{digits}f}"


def thousands(value: float, digits: int = 0) -> str:
    """With thousands separators: 12,345 (``digits`` after the point)."""
    return f"{value:,.{digits}f}"


def signed(value: float, digits: int = 4) -> str:
    """With its sign: +0.0123, −0.5 written -0.5."""
    return f"{value:+.{digits}f}"


def percent(share: float, digits: int = 0) -> str:
    """A share as a percentage: 0.123 → 12%."""
    return f"{share:.{digits}%}"


def interval(low: float, high: float, digits: int = 4, sign: bool = True) -> str:
    """``low to high``, each signed (or not)."""
    shape = f"{{:{'+' if sign else ''}.{digits}f}}"
    return f"{shape.format(low)} to {shape.format(high)}"


def difference(row, name: str, digits: int = 4) -> str:
    """A paired difference with its interval, from a table row's ``name``, ``name_low`` and
    ``name_high``: +0.0123 (-0.0100 to +0.0346)."""
    shape = f"{{:+.{digits}f}}"
    return (f"{shape.format(row[name])} ({shape.format(row[name + '_low'])} to "
            f"{shape.format(row[name + '_high'])})")


def side(row, name: str, below: str = "below 0", above: str = "above 0",
         across: str = "across 0") -> str:
    """Where a paired difference's interval lies, from a row's ``name_low`` and
    ``name_high``."""
    if row[name + "_high"] < 0:
        return below
    return above if row[name + "_low"] > 0 else across


def is_missing(value: object) -> bool:
    """A table's empty cell (NaN or None)."""
    return value is None or (isinstance(value, float) and math.isnan(value))


FILTERS = {"g": g, "fixed": fixed, "thousands": thousands, "signed": signed,
           "percent": percent}
GLOBALS = {"interval": interval, "is_missing": is_missing, "difference": difference,
           "side": side, "experiments": list(EXPERIMENTS)}
