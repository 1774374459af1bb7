"""Rangefinder (paper §3, §5.2; docs/design.md, "The authors' code" 3) and the wall-culling grid.

Beam i points at heading + beam_angles[i] (right to left) from the pose at the front bumper;
its reading is the distance to the nearest wall or vehicle-body edge it crosses, or the range
when it crosses none. Readings are raw metres, as the authors feed them to the network.

Walls are culled with a uniform grid: each cell lists the walls within reach of any point in
the cell, so a sensing step only tests the walls that can matter (docs/design.md, "Speed").
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit


class WallGrid(NamedTuple):
    """Walls and, per grid cell, the indices of the walls within ``reach`` of the cell. The
    compiled kernels take its numbers as fields of a tuple (:class:`WallGrid` itself, or
    :class:`enn_traffic.sim.rules.Physics`) and its arrays as arguments: a compiled function
    that takes an array out of a tuple it was given is many times slower."""

    walls: np.ndarray  # (S, 4)
    cell_x0: float  # lower-left corner of cell (0, 0)
    cell_y0: float
    cell_size: float
    cells_x: int
    cells_y: int
    cell_start: np.ndarray  # (cells_x * cells_y + 1,) CSR offsets into cell_walls
    cell_walls: np.ndarray  # wall indices
    all_walls: np.ndarray  # arange(S): the fallback outside the grid

    @classmethod
    def build(cls, walls: np.ndarray, reach: float, cell_size: float = 5.0) -> WallGrid:
        walls = np.ascontiguousarray(walls, dtype=np.float64)
        low = np.minimum(walls[:, :2], walls[:, 2:]).min(axis=0) - reach
        high = np.maximum(walls[:, :2], walls[:, 2:]).max(axis=0) + reach
        nx, ny = np.ceil((high - low) / cell_size).astype(int)
        cx = low[0] + (np.arange(nx) + 0.5) * cell_size
        cy = low[1] + (np.arange(ny) + 0.5) * cell_size
        centres = np.stack(np.meshgrid(cx, cy, indexing="ij"), axis=-1).reshape(-1, 2)
        limit = reach + cell_size * math.sqrt(0.5)
        starts, members = [0], []
        # chunk over cells to keep the (cells, walls) distance matrix small
        for chunk in np.array_split(centres, max(1, len(centres) // 2048)):
            near = point_segment_distance(chunk, walls) <= limit
            for row in near:
                idx = np.flatnonzero(row)
                members.append(idx)
                starts.append(starts[-1] + len(idx))
        cell_walls = np.concatenate(members) if members else np.empty(0, dtype=np.int64)
        return cls(
            walls=walls,
            cell_x0=float(low[0]),
            cell_y0=float(low[1]),
            cell_size=float(cell_size),
            cells_x=int(nx),
            cells_y=int(ny),
            cell_start=np.asarray(starts, dtype=np.int64),
            cell_walls=cell_walls.astype(np.int64),
            all_walls=np.arange(len(walls), dtype=np.int64),
        )


def point_segment_distance(points: np.ndarray, walls: np.ndarray) -> np.ndarray:
    """Distances (n_points, n_walls) from each point to each wall segment."""
    a, b = walls[None, :, :2], walls[None, :, 2:]
    p = points[:, None, :]
    ab = b - a
    t = np.clip(((p - a) * ab).sum(-1) / np.maximum((ab * ab).sum(-1), 1e-300), 0.0, 1.0)
    closest = a + t[..., None] * ab
    return np.linalg.norm(p - closest, axis=-1)


@njit(cache=True, inline="always")
def nearby_walls(x, y, grid, cell_start, cell_walls, all_walls):
    """The wall indices to test for a vehicle at (x, y) (``grid``: the numbers of a
    :class:`WallGrid`, the other arguments its arrays)."""
    i = int(math.floor((x - grid.cell_x0) / grid.cell_size))
    j = int(math.floor((y - grid.cell_y0) / grid.cell_size))
    if i < 0 or j < 0 or i >= grid.cells_x or j >= grid.cells_y:
        return all_walls
    cell = i * grid.cells_y + j
    return cell_walls[cell_start[cell] : cell_start[cell + 1]]


@njit(cache=True)
def ray_segment_distance(x, y, ux, uy, max_range, x1, y1, x2, y2) -> float:
    """Distance along the ray (x, y) + t·(ux, uy), 0 <= t <= max_range, to the segment, or
    ``max_range`` when it misses. Parallel pairs miss."""
    ex, ey = x2 - x1, y2 - y1
    den = ux * ey - uy * ex
    if den == 0.0:
        return max_range
    gx, gy = x1 - x, y1 - y
    t = (gx * ey - gy * ex) / den
    s = (gx * uy - gy * ux) / den
    if 0.0 <= t <= max_range and 0.0 <= s <= 1.0:
        return t
    return max_range


@njit(cache=True, inline="always")
def sense_walls(x, y, heading, beam_cos, beam_sin, max_range, walls, candidates, readings):
    """Fill ``readings`` with each beam's distance to the nearest candidate wall.

    ``beam_cos``, ``beam_sin`` hold the cosine and sine of each beam angle; the directions are
    those rotated by the heading: two trigonometric calls per step instead of two per beam.
    """
    cos_h, sin_h = math.cos(heading), math.sin(heading)
    for b in range(beam_cos.shape[0]):
        ux = cos_h * beam_cos[b] - sin_h * beam_sin[b]
        uy = sin_h * beam_cos[b] + cos_h * beam_sin[b]
        best = max_range
        for w in candidates:
            d = ray_segment_distance(
                x, y, ux, uy, best, walls[w, 0], walls[w, 1], walls[w, 2], walls[w, 3]
            )
            if d < best:
                best = d
        readings[b] = best
