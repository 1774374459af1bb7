"""Segment and box tests, and the body rectangle of a vehicle.

The body spans [-length, 0] along the heading and [-width/2, width/2] across it, measured from
the pose at the middle of the front bumper (docs/design.md, "The authors' code" 2).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit


@njit(cache=True, inline="always")
def body_corners(x, y, heading, length, width, out):
    """Fill ``out`` (4, 2) with the corners front-right, front-left, rear-left, rear-right."""
    cos_h, sin_h = math.cos(heading), math.sin(heading)
    nx, ny = -sin_h * 0.5 * width, cos_h * 0.5 * width
    rx, ry = x - length * cos_h, y - length * sin_h
    out[0, 0], out[0, 1] = x - nx, y - ny
    out[1, 0], out[1, 1] = x + nx, y + ny
    out[2, 0], out[2, 1] = rx + nx, ry + ny
    out[3, 0], out[3, 1] = rx - nx, ry - ny


@njit(cache=True)
def segments_intersect(ax, ay, bx, by, cx, cy, dx, dy) -> bool:
    """Do segments AB and CD meet (ends included)? Parallel pairs never do
    (docs/design.md, "The authors' code" 3)."""
    ex, ey = bx - ax, by - ay
    fx, fy = dx - cx, dy - cy
    den = ex * fy - ey * fx
    if den == 0.0:
        return False
    gx, gy = cx - ax, cy - ay
    s = (gx * fy - gy * fx) / den
    t = (gx * ey - gy * ex) / den
    return 0.0 <= s <= 1.0 and 0.0 <= t <= 1.0


@njit(cache=True)
def point_in_box(px, py, corners) -> bool:
    """Is P inside the convex quadrilateral ``corners`` (4, 2), given counter-clockwise?"""
    for i in range(4):
        j = (i + 1) % 4
        ex, ey = corners[j, 0] - corners[i, 0], corners[j, 1] - corners[i, 1]
        if ex * (py - corners[i, 1]) - ey * (px - corners[i, 0]) < 0.0:
            return False
    return True


@njit(cache=True)
def box_hits_segment(corners, x1, y1, x2, y2) -> bool:
    """Does the body ``corners`` touch segment (x1, y1)-(x2, y2)? An edge crossing, or the
    segment lying inside the body."""
    for i in range(4):
        j = (i + 1) % 4
        if segments_intersect(
            corners[i, 0], corners[i, 1], corners[j, 0], corners[j, 1], x1, y1, x2, y2
        ):
            return True
    return point_in_box(x1, y1, corners)


@njit(cache=True, inline="always")
def box_hits_walls(corners, walls, candidates, count) -> bool:
    """Does the body touch any of the first ``count`` wall indices in ``candidates``?"""
    for k in range(count):
        w = candidates[k]
        if box_hits_segment(corners, walls[w, 0], walls[w, 1], walls[w, 2], walls[w, 3]):
            return True
    return False


@njit(cache=True, inline="always")
def body_hits_walls(corners, cx, cy, radius, walls, candidates) -> bool:
    """:func:`box_hits_walls` for a body whose corners lie within ``radius`` of (cx, cy):
    a wall farther than that from the centre cannot touch it and is not tested."""
    reach = (radius + 1e-9) ** 2
    for w in candidates:
        x1, y1, x2, y2 = walls[w, 0], walls[w, 1], walls[w, 2], walls[w, 3]
        if (point_segment_distance_squared(cx, cy, x1, y1, x2, y2) <= reach
                and box_hits_segment(corners, x1, y1, x2, y2)):
            return True
    return False


@njit(cache=True, inline="always")
def point_segment_distance_squared(px, py, x1, y1, x2, y2) -> float:
    """Squared distance from P to the segment (x1, y1)-(x2, y2)."""
    ex, ey = x2 - x1, y2 - y1
    length = ex * ex + ey * ey
    t = 0.0 if length == 0.0 else min(max(((px - x1) * ex + (py - y1) * ey) / length, 0.0), 1.0)
    dx, dy = x1 + t * ex - px, y1 + t * ey - py
    return dx * dx + dy * dy


@njit(cache=True)
def boxes_overlap(a, b) -> bool:
    """Do two bodies (4, 2 corners each) overlap? Edge crossings or one inside the other."""
    for i in range(4):
        j = (i + 1) % 4
        if box_hits_segment(b, a[i, 0], a[i, 1], a[j, 0], a[j, 1]):
            return True
    return point_in_box(b[0, 0], b[0, 1], a)


def body_polygon(x: float, y: float, heading: float, length: float, width: float) -> np.ndarray:
    """Corners (4, 2) of a body, for drawing and tests."""
    out = np.empty((4, 2))
    body_corners(x, y, heading, length, width, out)
    return out
