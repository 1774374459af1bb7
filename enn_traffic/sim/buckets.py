"""Points bucketed by square cells (a spatial hash): the points near a place in a few reads,
however many there are.

A learner among a city's traffic senses and blames only bodies within its reach (its longest
beam and a body's bounding radius, docs/sumo.md). Looking through every vehicle of the city
for those costs learners × vehicles; the 3 × 3 cells of side ``reach`` around the learner hold
every point within ``reach`` of it. Cells hash into a power-of-two table of buckets, so a city
of any extent needs no grid of its size; points of two cells that share a bucket come along as
extra candidates, which the rules' own distance tests skip.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit


class Buckets(NamedTuple):
    """Up to N points by bucket: bucket ``b`` holds ``order[start[b]:start[b + 1]]``."""

    start: np.ndarray  # (B + 1,) int64; B a power of two, at least 2 N
    order: np.ndarray  # (N,) int64 point indices, by bucket, ascending within each
    cursor: np.ndarray  # (B,) int64 work array
    cell: np.ndarray  # (1,) float64 the cells' side (m)


def buckets_for(points: int) -> Buckets:
    """Room for ``points`` points."""
    table = 1 << max(4, (2 * max(points, 1) - 1).bit_length())
    return Buckets(np.zeros(table + 1, dtype=np.int64), np.zeros(max(points, 1), dtype=np.int64),
                   np.zeros(table, dtype=np.int64), np.ones(1))


@njit(cache=True, inline="always")
def _cell(coordinate, cell) -> int:
    """The column (or row) of the cell that holds ``coordinate``."""
    return np.int64(math.floor(coordinate / cell))


@njit(cache=True, inline="always")
def _bucket(column, row, mask) -> int:
    """The bucket of cell (``column``, ``row``): the two mixed (splitmix64's finaliser), so
    that neighbouring cells spread over the table."""
    h = column * np.int64(73856093) ^ row * np.int64(19349663)
    h = (h ^ (h >> 31)) * np.int64(-4658895280553007687)
    h = (h ^ (h >> 27)) * np.int64(-7723592293110705685)
    return (h ^ (h >> 33)) & mask


@njit(cache=True)
def fill(buckets, centres, present, cell) -> None:
    """Bucket the ``present`` rows of ``centres`` (N, 2) in cells of side ``cell``."""
    start, order, cursor = buckets.start, buckets.order, buckets.cursor
    mask = cursor.shape[0] - 1
    buckets.cell[0] = cell
    start[:] = 0
    for i in range(centres.shape[0]):
        if present[i]:
            start[_bucket(_cell(centres[i, 0], cell), _cell(centres[i, 1], cell), mask)] += 1
    total = 0
    for b in range(cursor.shape[0]):
        count = start[b]
        start[b] = cursor[b] = total
        total += count
    start[cursor.shape[0]] = total
    for i in range(centres.shape[0]):  # ascending: each bucket's points stay in order
        if present[i]:
            b = _bucket(_cell(centres[i, 0], cell), _cell(centres[i, 1], cell), mask)
            order[cursor[b]] = i
            cursor[b] += 1


@njit(cache=True)
def nearby(buckets, x, y, out) -> int:
    """Into ``out[:n]`` (room for N), ascending and each once, the points of the 3 × 3 cells
    around (x, y): every point within the cells' side of it, and maybe others. Returns ``n``."""
    start, order = buckets.start, buckets.order
    mask = buckets.cursor.shape[0] - 1
    cell = buckets.cell[0]
    column, row = _cell(x, cell), _cell(y, cell)
    n = 0
    for j in range(9):
        b = _bucket(column + j // 3 - 1, row + j % 3 - 1, mask)
        seen = False  # two of the cells may share a bucket: read it once
        for i in range(j):
            seen = seen or _bucket(column + i // 3 - 1, row + i % 3 - 1, mask) == b
        if not seen:
            for i in range(start[b], start[b + 1]):
                out[n] = order[i]
                n += 1
    out[:n].sort()
    return n
