"""A surrogate safety measure over the bodies' footprints: the two-dimensional time to
collision (docs/sumo.md, "Safety figures").

SUMO's SSM device pairs vehicles along lanes, so a learner that side-swipes a car in the next
lane, or crosses a road, leaves no conflict there. This measure pairs every body in the plane:
the time until two footprints (rectangles, as the blame rule sees them) first touch if each
keeps its velocity, the 2-D extension of time to collision (Ward, Agarwal, Bärgman et al.,
"Extending time to collision for probabilistic reasoning in general traffic scenarios",
Transportation Research Part C 51, 2015), computed exactly for convex bodies by the
separating-axis test in time: two convex polygons touch when their projections on every
edge normal overlap, and each normal gives the time interval in which they do.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from enn_traffic.sumo import ssm

CONFLICT_TTC = ssm.SSM_THRESHOLDS["TTC"]  # below it, a 2-D conflict, as SSM's TTC conflict


@njit(cache=True)
def time_to_contact(a: np.ndarray, b: np.ndarray, vx: float, vy: float) -> float:
    """Seconds until body ``b`` (4, 2 corners, in order round it) first touches body ``a``
    when ``b`` moves at (``vx``, ``vy``) m/s relative to ``a``; 0 when they touch now, inf
    when they never do."""
    enter, leave = 0.0, math.inf
    for body in (a, b):
        for i in range(4):
            j = (i + 1) % 4
            nx, ny = body[i, 1] - body[j, 1], body[j, 0] - body[i, 0]  # an edge's normal
            a_low, a_high = _projection(a, nx, ny)
            b_low, b_high = _projection(b, nx, ny)
            speed = vx * nx + vy * ny  # b's travel along the normal, per second
            if speed == 0.0:
                if b_high < a_low or b_low > a_high:
                    return math.inf  # apart on this axis for good
                continue
            first, last = (a_low - b_high) / speed, (a_high - b_low) / speed
            if speed < 0.0:
                first, last = last, first
            enter, leave = max(enter, first), min(leave, last)
            if enter > leave:
                return math.inf
    return enter


@njit(cache=True, inline="always")
def _projection(body: np.ndarray, nx: float, ny: float) -> tuple[float, float]:
    low = high = body[0, 0] * nx + body[0, 1] * ny
    for k in range(1, body.shape[0]):
        value = body[k, 0] * nx + body[k, 1] * ny
        low, high = min(low, value), max(high, value)
    return low, high


@njit(cache=True, inline="always")
def _centre(corners: np.ndarray) -> tuple[float, float]:
    """The middle of a body's four corners."""
    return (0.25 * (corners[0, 0] + corners[1, 0] + corners[2, 0] + corners[3, 0]),
            0.25 * (corners[0, 1] + corners[1, 1] + corners[2, 1] + corners[3, 1]))


@njit(cache=True)
def least_time_to_contact(corners: np.ndarray, vx: float, vy: float, ids: np.ndarray,
                          gone: np.ndarray, slot_corners: np.ndarray, slot_centres: np.ndarray,
                          before: int, now: int, dt: float, reach: float) -> float:
    """The least :func:`time_to_contact` between a vehicle (``corners`` (4, 2), moving at
    (``vx``, ``vy``)) and the bodies in the slot arrays' row ``now`` within ``reach`` metres
    of it, each moving as it did since row ``before`` (``dt`` seconds earlier; at rest when
    its slot held another vehicle then); a vehicle that has left the learner's world (its id
    in ``gone``: cleared from its start, or after running into it) is not there for it, as
    for the blame rule. inf when none is within reach or none comes closer."""
    x, y = _centre(corners)
    least = math.inf
    for s in range(ids.shape[1]):
        if ids[now, s] < 0 or ids[now, s] == gone[s]:
            continue
        cx, cy = slot_centres[now, s, 0], slot_centres[now, s, 1]
        if (cx - x) ** 2 + (cy - y) ** 2 > reach * reach:
            continue
        ux = uy = 0.0
        if ids[before, s] == ids[now, s]:
            ux = (cx - slot_centres[before, s, 0]) / dt
            uy = (cy - slot_centres[before, s, 1]) / dt
        least = min(least, time_to_contact(corners, slot_corners[now, s], ux - vx, uy - vy))
    return least


@njit(cache=True, inline="always")
def may_meet(px: float, py: float, ux: float, uy: float, gap: float, horizon: float) -> bool:
    """Do two points ``(px, py)`` apart, moving at (``ux``, ``uy``) m/s relative to each other,
    come within ``gap`` of each other in the next ``horizon`` seconds? Two bodies whose bounding
    circles (diameter ``gap`` together) never meet in that time cannot touch in it."""
    speed2 = ux * ux + uy * uy
    t = 0.0 if speed2 == 0.0 else min(max(-(px * ux + py * uy) / speed2, 0.0), horizon)
    dx, dy = px + ux * t, py + uy * t
    return dx * dx + dy * dy <= gap * gap


@njit(cache=True, inline="always")
def least_time_among(corners: np.ndarray, vx: float, vy: float, bodies: np.ndarray,
                     centres: np.ndarray, velocities: np.ndarray, skip: np.ndarray, gap: float,
                     horizon: float) -> float:
    """The least :func:`time_to_contact` below ``horizon`` seconds between a vehicle
    (``corners`` (4, 2), moving at (``vx``, ``vy``) m/s) and ``bodies`` (n, 4, 2) centred at
    ``centres`` and moving at ``velocities`` (n, 2), leaving out those ``skip`` marks; bodies
    whose bounding circles (``gap`` the sum of two radii) do not meet within ``horizon`` are
    not tried. inf when none comes that close."""
    x, y = _centre(corners)
    least = math.inf
    for i in range(bodies.shape[0]):
        if skip[i]:
            continue
        ux, uy = velocities[i, 0] - vx, velocities[i, 1] - vy
        if may_meet(centres[i, 0] - x, centres[i, 1] - y, ux, uy, gap, horizon):
            least = min(least, time_to_contact(corners, bodies[i], ux, uy))
    return least if least < horizon else math.inf
