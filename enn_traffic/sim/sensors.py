"""Rangefinder (paper §3, §5.2; docs/design.md, "The authors' code" 3) and the wall-culling grid.

Beam i points at heading + its angle from the pose at the front bumper (the scenario's rings
of beams, :attr:`enn_traffic.config.Scenario.beams`); its reading is the distance to the
nearest wall or vehicle-body edge it crosses, or its range when it crosses none. Readings are
raw metres, as the authors feed them to the network. Further channels (``[sensor] channels``:
the closing speed of what a beam meets) follow the distances, every beam's each
(:mod:`enn_traffic.sim.readings`).

Walls are culled with a uniform grid: each cell lists the walls within reach of any point in
the cell, so a sensing step only tests the walls that can matter (docs/design.md, "Speed").
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit

from enn_traffic.core import cache
from enn_traffic.core.errors import InputError
from enn_traffic.core.progress import slow_step
from enn_traffic.sim.readings import (
    COS,
    FAN_ANGLE,
    FAN_BEAM,
    RANGE,
    SIN,
    clear_seen,
    fill_channels,
    note_seen,
)

GRID_VERSION = 1  # raised when the cells a grid lists change
CELL_SIZE = 5.0  # m: the side of a wall grid's cells
# A grid's cells (1.6 GB of offsets): a city 70 km across at 5 m cells. A network larger than
# that is refused with the reason, not left to fail allocating (coordinates of 1e12 m).
MAX_GRID_CELLS = 200_000_000


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
    def build(cls, walls: np.ndarray, reach: float, cell_size: float = CELL_SIZE) -> WallGrid:
        """The grid over ``walls`` whose cells list every wall within ``reach`` of any point
        of the cell (a wall within ``reach`` plus half the cell's diagonal of its centre).

        Each wall is binned into the cells its bounding box, widened by that distance, covers,
        and kept in those whose centre is near enough: the work grows with the walls and the
        cells near each, not with cells × walls (a city of 5,500 walls over 4 × 3 km: 0.5 s
        instead of 350 s, docs/bench.md). A cell lists its walls in ascending order."""
        walls = np.ascontiguousarray(walls, dtype=np.float64).reshape(-1, 4)
        low = np.minimum(walls[:, :2], walls[:, 2:]).min(axis=0) - reach
        high = np.maximum(walls[:, :2], walls[:, 2:]).max(axis=0) + reach
        nx, ny = (math.ceil(side / cell_size) for side in high - low)
        if nx * ny > MAX_GRID_CELLS:  # refused before anything of its size is allocated
            width, height = (high - low) / 1000
            raise InputError(
                f"its walls span {width:,.3g} km × {height:,.3g} km: the rangefinder's grid "
                f"of {cell_size:g} m cells would need {nx * ny:,.3g} cells, more than "
                f"{MAX_GRID_CELLS:,} (coordinates in metres, as SUMO's netconvert writes them?)")
        limit = reach + cell_size * math.sqrt(0.5)
        cells, members = [], []
        for chunk in _chunks_of_pairs(walls, low, cell_size, limit, nx, ny):
            first, last, cell_lo, span_x, span_y = chunk
            per_wall = span_x * span_y
            wall = np.repeat(np.arange(first, last), per_wall)
            offset = np.arange(per_wall.sum()) - np.repeat(np.cumsum(per_wall) - per_wall,
                                                           per_wall)
            span_y_each = np.repeat(span_y, per_wall)
            i = np.repeat(cell_lo[:, 0], per_wall) + offset // span_y_each
            j = np.repeat(cell_lo[:, 1], per_wall) + offset % span_y_each
            centres = np.column_stack([low[0] + (i + 0.5) * cell_size,
                                       low[1] + (j + 0.5) * cell_size])
            near = pair_distance(centres, walls[wall]) <= limit
            cells.append(i[near] * ny + j[near])
            members.append(wall[near])
        cell = np.concatenate(cells) if cells else np.empty(0, dtype=np.int64)
        member = np.concatenate(members) if members else np.empty(0, dtype=np.int64)
        order = np.argsort(cell, kind="stable")  # walls were binned in ascending order
        counts = np.bincount(cell, minlength=nx * ny)
        return cls(
            walls=walls,
            cell_x0=float(low[0]),
            cell_y0=float(low[1]),
            cell_size=float(cell_size),
            cells_x=int(nx),
            cells_y=int(ny),
            cell_start=np.concatenate([[0], np.cumsum(counts)]).astype(np.int64),
            cell_walls=member[order].astype(np.int64),
            all_walls=np.arange(len(walls), dtype=np.int64),
        )

    @classmethod
    def cached(cls, walls: np.ndarray, reach: float) -> WallGrid:
        """:meth:`build` with cells of :data:`CELL_SIZE`, kept on disk by the walls' bytes and
        ``reach`` (:mod:`enn_traffic.core.cache`)."""
        cell_size = CELL_SIZE
        walls = np.ascontiguousarray(walls, dtype=np.float64).reshape(-1, 4)
        key = cache.key_of(walls.tobytes(), repr(reach), repr(cell_size), GRID_VERSION)

        def build() -> dict[str, np.ndarray]:
            with slow_step(f"indexing {len(walls):,} walls for the rangefinder"):
                grid = cls.build(walls, reach, cell_size)
            numbers = [grid.cell_x0, grid.cell_y0, grid.cell_size, grid.cells_x, grid.cells_y]
            return {"numbers": np.array(numbers, dtype=np.float64),
                    "cell_start": grid.cell_start, "cell_walls": grid.cell_walls}

        arrays = cache.cached_arrays("grids", key, build)
        x0, y0, size, cells_x, cells_y = arrays["numbers"]
        return cls(walls=walls, cell_x0=float(x0), cell_y0=float(y0), cell_size=float(size),
                   cells_x=int(cells_x), cells_y=int(cells_y), cell_start=arrays["cell_start"],
                   cell_walls=arrays["cell_walls"],
                   all_walls=np.arange(len(walls), dtype=np.int64))


PAIRS_PER_CHUNK = 250_000  # (cell, wall) candidates tested at once: bounds the memory


def _chunks_of_pairs(walls, low, cell_size, limit, nx, ny):
    """Runs of consecutive walls, each with the first cell (i, j) and the number of cells
    along x and y of every wall's bounding box widened by ``limit``, so that a run holds
    about ``PAIRS_PER_CHUNK`` candidate (cell, wall) pairs."""
    lo_xy = np.minimum(walls[:, :2], walls[:, 2:]) - limit - low
    hi_xy = np.maximum(walls[:, :2], walls[:, 2:]) + limit - low
    # the cells whose centre low + (i + 0.5) * cell_size lies in [lo, hi], and one more on
    # each side, so that no rounding drops a cell that the exact test below would keep
    cell_lo = np.clip(np.ceil(lo_xy / cell_size - 0.5) - 1, 0, None).astype(np.int64)
    cell_hi = np.minimum(np.floor(hi_xy / cell_size - 0.5).astype(np.int64) + 1,
                         [nx - 1, ny - 1])
    span = np.maximum(cell_hi - cell_lo + 1, 0)
    pairs = np.cumsum(span[:, 0] * span[:, 1])  # candidates up to and including each wall
    first = 0
    while first < len(walls):
        before = pairs[first - 1] if first else 0
        last = max(int(np.searchsorted(pairs, before + PAIRS_PER_CHUNK, "right")), first + 1)
        yield first, last, cell_lo[first:last], span[first:last, 0], span[first:last, 1]
        first = last


def pair_distance(points: np.ndarray, walls: np.ndarray) -> np.ndarray:
    """Distance from each point (n, 2) to the wall segment (n, 4) of the same row."""
    return point_segment_distance(points[:, None, :], walls[:, None, :])[:, 0]


def point_segment_distance(points: np.ndarray, walls: np.ndarray) -> np.ndarray:
    """Distances (n_points, n_walls) from each point (n_points, 2) to each wall segment
    (n_walls, 4); or, given arrays already shaped to broadcast ((n, 1, 2) and (n, 1, 4)),
    row by row."""
    if points.ndim == 2:
        points, walls = points[:, None, :], walls[None, :, :]
    a, b = walls[..., :2], walls[..., 2:]
    p = points
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
def sense_walls(x, y, cos_h, sin_h, beams, walls, candidates, readings):
    """Fill ``readings`` with each beam's distance to the nearest candidate wall (its range
    when none is nearer), for a vehicle at (x, y) whose heading has cosine ``cos_h`` and sine
    ``sin_h``; ``beams`` is a :func:`beam_table`, a beam's direction its row's rotated by the
    heading. Each wall is tested only along the beams within its angular extent
    (:func:`beams_across`): the nearest hit along a beam is the same, found with a fraction
    of the ray tests (docs/bench.md, "Instructions").
    """
    for b in range(beams.shape[0]):
        readings[b] = beams[b, RANGE]
    for w in candidates:
        x1, y1, x2, y2 = walls[w, 0], walls[w, 1], walls[w, 2], walls[w, 3]
        lo, hi = beams_across(x1 - x, y1 - y, x2 - x, y2 - y, cos_h, sin_h, beams)
        for rank in range(lo, hi + 1):
            b = int(beams[rank, FAN_BEAM])
            ux = cos_h * beams[b, COS] - sin_h * beams[b, SIN]
            uy = sin_h * beams[b, COS] + cos_h * beams[b, SIN]
            d = ray_segment_distance(x, y, ux, uy, readings[b], x1, y1, x2, y2)
            if d < readings[b]:
                readings[b] = d


@njit(cache=True, inline="always")
def first_rank_from(beams, angle) -> int:
    """The first rank whose beam angle is ``angle`` or more (the number of beams if none)."""
    lo, hi = 0, beams.shape[0]
    while lo < hi:
        middle = (lo + hi) // 2
        if beams[middle, FAN_ANGLE] < angle:
            lo = middle + 1
        else:
            hi = middle
    return lo


@njit(cache=True, inline="always")
def last_rank_to(beams, angle) -> int:
    """The last rank whose beam angle is ``angle`` or less (-1 if none)."""
    lo, hi = 0, beams.shape[0]
    while lo < hi:
        middle = (lo + hi) // 2
        if beams[middle, FAN_ANGLE] <= angle:
            lo = middle + 1
        else:
            hi = middle
    return lo - 1


ANGLE_MARGIN = 1e-4  # rad: windows of beams are widened by this much, 5× rough_atan2's error


@njit(cache=True, inline="always")
def rough_atan2(y, x) -> float:
    """atan2(y, x) to within 2e-5 rad (Abramowitz & Stegun 4.4.49: a polynomial of degree 9
    on [0, 1], the octants by symmetry), for the beam windows: a fifth of the libm call's
    instructions. 0 at the origin."""
    ax, ay = abs(x), abs(y)
    if ax == 0.0 and ay == 0.0:
        return 0.0
    steep = ay > ax
    z = ax / ay if steep else ay / ax
    z2 = z * z
    angle = z * (0.9998660 + z2 * (-0.3302995 + z2 * (0.1801410 + z2 * (-0.0851330
                                                                        + z2 * 0.0208351))))
    if steep:
        angle = 0.5 * math.pi - angle
    if x < 0.0:
        angle = math.pi - angle
    return -angle if y < 0.0 else angle


@njit(cache=True, inline="always")
def beams_across(ax, ay, bx, by, cos_h, sin_h, beams):
    """The first and last rank (``beams``: a :func:`beam_table`) of the beams, relative to the
    heading ``cos_h``, ``sin_h``, whose direction lies between those of the segment's ends
    (``ax``, ``ay``) and (``bx``, ``by``), relative to the vehicle: the only beams that can
    cross the segment. Widened by ``ANGLE_MARGIN``; every rank when the segment passes
    (nearly) through the vehicle or when its extent straddles the bearing ±π and beams lie on
    both sides; an empty range (lo > hi) when none lies between."""
    count = beams.shape[0]
    if count == 1:
        return 0, 0
    alpha = rough_atan2(ay * cos_h - ax * sin_h, ax * cos_h + ay * sin_h)
    beta = rough_atan2(by * cos_h - bx * sin_h, bx * cos_h + by * sin_h)
    low, high = min(alpha, beta), max(alpha, beta)
    extent = high - low
    if abs(extent - math.pi) < 2.0 * ANGLE_MARGIN:
        return 0, count - 1
    if extent < math.pi:
        return (first_rank_from(beams, low - ANGLE_MARGIN),
                last_rank_to(beams, high + ANGLE_MARGIN))
    # the extent runs from high up through ±π to low: beams at or past either end
    above = first_rank_from(beams, high - ANGLE_MARGIN)  # ranks >= above
    below = last_rank_to(beams, low + ANGLE_MARGIN)  # ranks <= below
    if above <= count - 1 and below >= 0:
        return 0, count - 1
    if above <= count - 1:
        return above, count - 1
    return 0, below


@njit(cache=True, inline="always")
def beams_towards(ahead, left, distance, radius, beams):
    """The first and last rank (``beams``: a :func:`beam_table`) of the beams that may pass
    within ``radius`` of a point ``ahead``, ``left`` of the vehicle and ``distance`` (more
    than twice ``radius``) from it: those within asin(radius / distance) of its bearing. The
    window is taken wider, never narrower: the bearing by :func:`rough_atan2` widened by
    ``ANGLE_MARGIN``, the half-width by tan(asin z) = z / sqrt(1 − z²) ≥ asin z. An empty
    range (lo > hi) when no beam lies in it; every rank when the window wraps past ±π."""
    bearing = rough_atan2(left, ahead)
    z = radius / distance
    half = z / math.sqrt(1.0 - z * z) + ANGLE_MARGIN
    if bearing - half < -math.pi or bearing + half > math.pi:
        return 0, beams.shape[0] - 1
    return first_rank_from(beams, bearing - half), last_rank_to(beams, bearing + half)


@njit(cache=True, inline="always")
def sense(v, pose, physics, beams, channels, walls, cell_start, cell_walls, all_walls, bodies,
          corners, centres, before, me, readings, seen) -> None:
    """Rangefinder readings of vehicle ``v`` (paper §3): the nearest wall along each beam and,
    when ``bodies``, the nearest edge of any other body (``corners``, ``centres``, and the
    centres a step ``before``; ``me``, its own there, skipped); then the further ``channels``
    (:func:`~enn_traffic.sim.readings.fill_channels`; ``seen``: a
    :func:`~enn_traffic.sim.readings.seen_for` work array)."""
    x, y, cos_h, sin_h = sense_walls_of(v, pose, physics, beams, walls, cell_start, cell_walls,
                                        all_walls, readings)
    clear_seen(seen)
    if bodies:
        sense_bodies(me, x, y, cos_h, sin_h, beams, corners, centres, before, physics.radius,
                     physics.dt, readings, seen)
    fill_channels(channels, beams, seen, cos_h, sin_h, physics.distance / physics.dt, readings)


@njit(cache=True, inline="always")
def sense_walls_of(v, pose, physics, beams, walls, cell_start, cell_walls, all_walls, readings):
    """The walls' half of :func:`sense`: vehicle ``v``'s readings of the nearest walls. Returns
    its position and its heading's cosine and sine."""
    x, y, heading = pose[v, 0], pose[v, 1], pose[v, 2]
    cos_h, sin_h = math.cos(heading), math.sin(heading)
    candidates = nearby_walls(x, y, physics, cell_start, cell_walls, all_walls)
    sense_walls(x, y, cos_h, sin_h, beams, walls, candidates, readings)
    return x, y, cos_h, sin_h


@njit(cache=True, inline="always")
def sense_bodies(me, x, y, cos_h, sin_h, beams, corners, centres, before, radius, dt, readings,
                 seen):
    """Lower ``readings`` of a vehicle at (x, y) (heading cosine ``cos_h``, sine ``sin_h``)
    to the nearest edge of any body but ``me`` (``beams``: a
    :func:`~enn_traffic.sim.readings.beam_table`), and where ``seen``
    (:func:`~enn_traffic.sim.readings.seen_for`) is an array, note there the velocity of the body
    each beam met, from its centre a step (``dt`` seconds) ``before``. A body is skipped when
    its bounding circle lies beyond every reading, and its edges are tested only along the
    beams that pass through that circle: those within the circle's angular half-width of its bearing
    (:func:`~enn_traffic.sim.sensors.beams_towards`), each checked as before. Of a body the
    vehicle is outside of, only the edges that face it are tested: a ray enters a convex body
    through one of those (:func:`facing_edges`)."""
    count = beams.shape[0]
    far = largest(readings, count) + radius + 1e-9  # readings only fall: a looser cut, same result
    for other in range(corners.shape[0]):
        if other == me:
            continue
        dx, dy = centres[other, 0] - x, centres[other, 1] - y
        squared = dx * dx + dy * dy
        if squared > far * far:
            continue
        lo, hi = 0, count - 1
        if squared > 4.0 * radius * radius and count > 1:
            lo, hi = beams_towards(dx * cos_h + dy * sin_h, dy * cos_h - dx * sin_h,
                                   math.sqrt(squared), radius, beams)
        if lo > hi:
            continue
        facing = facing_edges(corners[other], x, y)
        for rank in range(lo, hi + 1):
            b = int(beams[rank, FAN_BEAM])
            ux = cos_h * beams[b, COS] - sin_h * beams[b, SIN]
            uy = sin_h * beams[b, COS] + cos_h * beams[b, SIN]
            along = dx * ux + dy * uy
            if along < -radius or along - radius > readings[b] or abs(dx * uy - dy * ux) > radius:
                continue  # the beam passes clear of the body's bounding circle
            for i in range(4):
                if not facing & (1 << i):
                    continue
                j = (i + 1) % 4
                d = ray_segment_distance(
                    x, y, ux, uy, readings[b], corners[other, i, 0], corners[other, i, 1],
                    corners[other, j, 0], corners[other, j, 1],
                )  # fmt: skip
                if d < readings[b]:
                    readings[b] = d
                    note_seen(seen, b, (centres[other, 0] - before[other, 0]) / dt,
                              (centres[other, 1] - before[other, 1]) / dt)


EDGE_MARGIN = 1e-9  # m²: an edge nearly in line with the sensing point counts as facing it


@njit(cache=True, inline="always")
def facing_edges(body, x, y) -> int:
    """Bit i set when edge i (corner i to i + 1; corners counter-clockwise, as
    :func:`~enn_traffic.core.geometry.body_corners` lists them) faces (x, y), that is (x, y) lies
    on or beyond its outer side; every edge when (x, y) is inside the body."""
    mask = 0
    for i in range(4):
        j = (i + 1) % 4
        ex, ey = body[j, 0] - body[i, 0], body[j, 1] - body[i, 1]
        if ex * (y - body[i, 1]) - ey * (x - body[i, 0]) < EDGE_MARGIN:
            mask |= 1 << i
    return mask if mask else 15


@njit(cache=True, inline="always")
def largest(values, count) -> float:
    """The largest of the first ``count`` ``values`` (a loop: ``values.max()`` costs a reshape
    each call)."""
    top = values[0]
    for k in range(1, count):
        if values[k] > top:
            top = values[k]
    return top
