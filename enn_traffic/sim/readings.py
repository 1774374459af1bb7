"""What a rangefinder gives its network (paper §3, §5.2): the beams' table, the channels each
beam reads (``[sensor] channels``: the distance, then further channels such as the closing
speed of what it meets) and the readings' count and bounds, which every world, environment
and buffer asks here. The sensing itself is in :mod:`enn_traffic.sim.sensors`; the channels
after the distances are filled here (:func:`fill_channels`), from what
:func:`~enn_traffic.sim.sensors.sense_bodies` noted of the bodies each beam met.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, types
from numba.extending import overload

from enn_traffic.config.sensor import CHANNELS

# The beams as the kernels take them (:func:`beam_table`): one row per beam, in the network's
# input order, with its direction's cosine and sine relative to the heading and its range; and
# one row per rank of angle, right to left, with that angle and the beam that has it (a
# sensing step finds the beams that can reach a wall or a body by bisecting the angles).
COS, SIN, RANGE, FAN_ANGLE, FAN_BEAM = range(5)


def beam_table(beams: list[tuple[float, float]]) -> np.ndarray:
    """The (B, 5) table of ``beams``, each (angle relative to the heading in radians, range in
    metres), in the network's input order (paper §3: the rangefinder's beams)."""
    angles = np.array([angle for angle, _ in beams], dtype=np.float64)
    table = np.empty((len(beams), 5))
    table[:, COS], table[:, SIN] = np.cos(angles), np.sin(angles)
    table[:, RANGE] = [reach for _, reach in beams]
    # bearings are measured in [-π, π]: a beam past either end (a ring behind) is put back in
    angles = np.where(angles > math.pi, angles - 2 * math.pi,
                      np.where(angles < -math.pi, angles + 2 * math.pi, angles))
    order = np.argsort(angles, kind="stable")
    table[:, FAN_ANGLE], table[:, FAN_BEAM] = angles[order], order
    return table


# What a beam reads (``[sensor] channels``, named in enn_traffic.config.sensor.CHANNELS), as
# the codes the compiled step takes: a channel is its name there, its branch in
# :func:`fill_channels` and its bounds in :func:`reading_bounds`.
CODES = {name: code for code, name in enumerate(CHANNELS)}
DISTANCE, CLOSING_SPEED = CODES["distance"], CODES["closing_speed"]


def channel_codes(names: list[str]) -> np.ndarray | None:
    """The codes of the channels ``names`` (``[sensor] channels``), in their order; None for
    the distances alone. None is a type of its own to numba: the kernels compile without the
    channels' work, which slowed the arena batch when they carried it unused (docs/design.md,
    "Sensor channels' cost", A/B in results/house)."""
    if list(names) == ["distance"]:
        return None
    return np.array([CODES[name] for name in names], dtype=np.int64)


# The overloads here choose a body by type, None (the distances alone) or codes; each has one
# body per type, for compiled code (a call from Python says so). numba's own inliner
# (``inline="always"``) is not asked for them: with it, numba 0.68 compiled the arena's
# kernels into wrong poses.
COMPILED_ONLY = "called from compiled code only, where numba picks its body by type"


def channel_count(channels: np.ndarray | None) -> int:
    """How many channels each beam reads (``channels``: :func:`channel_codes`)."""
    raise TypeError(COMPILED_ONLY)


@overload(channel_count)
def _channel_count(channels):
    if isinstance(channels, types.NoneType):
        return lambda channels: 1
    return lambda channels: channels.shape[0]


@njit(cache=True)
def reading_count(geometry) -> int:
    """Readings a vehicle's sensor gives each step, the network's inputs: one per beam of the
    :func:`beam_table` and channel (every world, environment and buffer asks here, compiled
    kernels too). Channel by channel: the distances of every beam, then the next channel's."""
    return geometry.beams.shape[0] * channel_count(geometry.channels)


def reading_bounds(geometry) -> tuple[np.ndarray, np.ndarray]:
    """Each reading's least and greatest value, what an environment's observation space holds:
    a distance from 0 (a body at the sensor) to the beam's range (nothing within it); a
    closing speed is unbounded (SUMO's vehicles set their own speeds)."""
    ranges = geometry.beams[:, RANGE]
    codes = [DISTANCE] if geometry.channels is None else geometry.channels
    low, high = [], []
    for code in codes:
        if code == DISTANCE:
            low.append(np.zeros_like(ranges))
            high.append(ranges.copy())
        else:
            low.append(np.full_like(ranges, -np.inf))
            high.append(np.full_like(ranges, np.inf))
    return np.concatenate(low), np.concatenate(high)


def unseen_readings(geometry) -> np.ndarray:
    """What the sensor reads when it meets nothing: each beam's range, every further channel
    0."""
    readings = np.zeros(reading_count(geometry))
    readings[: geometry.beams.shape[0]] = geometry.beams[:, RANGE]
    return readings


@njit(cache=True)
def seen_for(beams, channels):
    """Room for what each beam meets, (B, 2), when ``channels`` go beyond the distance: the
    velocity of the body it meets (m/s; a wall's is 0), noted as the bodies are sensed; None
    for the distances alone, which need nothing noted. A work array, made once per world or
    observer: made at every sensing, it slowed the arena batch measurably."""
    return _seen_rows(beams, channels)


def _seen_rows(beams, channels):
    raise TypeError(COMPILED_ONLY)


@overload(_seen_rows)
def _seen_rows_of(beams, channels):
    if isinstance(channels, types.NoneType):
        return lambda beams, channels: None
    return lambda beams, channels: np.zeros((beams.shape[0], 2))


def work_row(array: np.ndarray | None, i: int) -> np.ndarray | None:
    """Row ``i`` of a stacked work array that may be None (:func:`seen_for`'s, per world)."""
    raise TypeError(COMPILED_ONLY)


@overload(work_row)
def _work_row(array, i):
    if isinstance(array, types.NoneType):
        return lambda array, i: None
    return lambda array, i: array[i]


def clear_seen(seen: np.ndarray | None) -> None:
    """Every beam of ``seen`` (:func:`seen_for`) meets a wall or nothing, until a body is
    sensed."""
    raise TypeError(COMPILED_ONLY)


@overload(clear_seen)
def _clear_seen(seen):
    if isinstance(seen, types.NoneType):
        return lambda seen: None

    def clear(seen):
        for b in range(seen.shape[0]):
            seen[b, 0], seen[b, 1] = 0.0, 0.0
    return clear


def note_seen(seen, b, vx, vy) -> None:
    """Beam ``b`` met a body moving at (``vx``, ``vy``) m/s: noted in ``seen``
    (:func:`seen_for`), nothing when it is None."""
    raise TypeError(COMPILED_ONLY)


@overload(note_seen)
def _note_seen(seen, b, vx, vy):
    if isinstance(seen, types.NoneType):
        return lambda seen, b, vx, vy: None

    def note(seen, b, vx, vy):
        seen[b, 0], seen[b, 1] = vx, vy
    return note


def fill_channels(channels, beams, seen, cos_h, sin_h, speed, readings) -> None:
    """The readings of every channel after the distances (``channels``: codes from
    :func:`channel_codes`; None, the distances alone: nothing to fill), for a vehicle whose
    heading has cosine ``cos_h`` and sine ``sin_h``, moving at ``speed`` (m/s); ``seen``:
    :func:`seen_for`, filled. A beam that reads its range met nothing.

    Closing speed: how fast the distance along the beam shrinks, the vehicle's velocity less
    what it met's, along the beam (m/s, negative when it draws away); 0 when it meets
    nothing."""
    raise TypeError(COMPILED_ONLY)


@overload(fill_channels)
def _fill_channels(channels, beams, seen, cos_h, sin_h, speed, readings):
    if isinstance(channels, types.NoneType):
        return lambda channels, beams, seen, cos_h, sin_h, speed, readings: None
    return lambda channels, beams, seen, cos_h, sin_h, speed, readings: fill_each_channel(
        channels, beams, seen, cos_h, sin_h, speed, readings)


@njit(cache=True, inline="always")
def fill_each_channel(channels, beams, seen, cos_h, sin_h, speed, readings) -> None:
    """:func:`fill_channels` where ``channels`` go beyond the distance."""
    count = beams.shape[0]
    vx, vy = speed * cos_h, speed * sin_h
    for c in range(1, channels.shape[0]):
        for b in range(count):
            value = 0.0
            if channels[c] == CLOSING_SPEED and readings[b] < beams[b, RANGE]:
                ux = cos_h * beams[b, COS] - sin_h * beams[b, SIN]
                uy = sin_h * beams[b, COS] + cos_h * beams[b, SIN]
                value = (vx - seen[b, 0]) * ux + (vy - seen[b, 1]) * uy
            readings[c * count + b] = value
