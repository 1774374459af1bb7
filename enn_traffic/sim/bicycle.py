"""Kinematic bicycle model (paper §4, Figure 4; docs/design.md, "The authors' code" 2).

The pose (x, y, heading) is the middle of the front bumper. Each step, a rear point half a
wheelbase behind the pose moves ``distance`` along the heading, a front point half a wheelbase
ahead moves ``distance`` along heading + steering; the new pose is their midpoint and the new
heading points from the rear point to the front point.
"""

from __future__ import annotations

import math

from numba import njit


@njit(cache=True, fastmath=False)
def bicycle_step(
    x: float, y: float, heading: float, steering: float, distance: float, wheelbase: float
) -> tuple[float, float, float]:
    """The pose after one step with steering angle ``steering`` (radians, positive = left)."""
    cos_h, sin_h = math.cos(heading), math.sin(heading)
    half = 0.5 * wheelbase
    rear_x = x - half * cos_h + distance * cos_h
    rear_y = y - half * sin_h + distance * sin_h
    front_x = x + half * cos_h + distance * math.cos(heading + steering)
    front_y = y + half * sin_h + distance * math.sin(heading + steering)
    return (
        0.5 * (front_x + rear_x),
        0.5 * (front_y + rear_y),
        math.atan2(front_y - rear_y, front_x - rear_x),
    )
