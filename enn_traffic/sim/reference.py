"""A plain per-vehicle Python loop of a life: the yardstick for ``bench``, the oracle for tests.

Same rules as :func:`enn_traffic.sim.arena.run_life`, written as simply as possible: one
vehicle at a time, every wall tested every step, no compilation.
"""

from __future__ import annotations

import math
from itertools import pairwise

import numpy as np

from enn_traffic.sim.arena import ArenaWorld
from enn_traffic.sim.sensors import point_segment_distance
from enn_traffic.sim.world import CAPPED, COLLIDED, SPUN


def _segments_intersect(ax, ay, bx, by, cx, cy, dx, dy):
    ex, ey, fx, fy = bx - ax, by - ay, dx - cx, dy - cy
    den = ex * fy - ey * fx
    if den == 0.0:
        return False
    gx, gy = cx - ax, cy - ay
    s = (gx * fy - gy * fx) / den
    t = (gx * ey - gy * ex) / den
    return 0.0 <= s <= 1.0 and 0.0 <= t <= 1.0


def _inside(px, py, corners):
    for i in range(4):
        (ax, ay), (bx, by) = corners[i], corners[(i + 1) % 4]
        if (bx - ax) * (py - ay) - (by - ay) * (px - ax) < 0.0:
            return False
    return True


def reference_life(world: ArenaWorld, chromosome: np.ndarray) -> tuple[int, int]:
    """(steps moved, outcome) of one chromosome, computed the slow, obvious way."""
    scenario = world.scenario
    genes = [float(g) for g in world.spec.in_source_layout(chromosome)[0]]
    sizes = list(scenario.layer_sizes)
    gain = math.radians(scenario.network.steering_gain_deg)
    vehicle, episode = scenario.vehicle, scenario.episode
    distance = vehicle.speed * vehicle.dt
    walls = [tuple(map(float, w)) for w in world.track.walls]
    beams = scenario.beams
    x, y, heading = world.start
    recent = []
    steps = 0
    while True:
        readings = []
        cos_h, sin_h = math.cos(heading), math.sin(heading)
        for angle, reach in beams:
            cos_b, sin_b = math.cos(angle), math.sin(angle)
            ux, uy = cos_h * cos_b - sin_h * sin_b, sin_h * cos_b + cos_h * sin_b
            best = reach
            for x1, y1, x2, y2 in walls:
                ex, ey = x2 - x1, y2 - y1
                den = ux * ey - uy * ex
                if den == 0.0:
                    continue
                gx, gy = x1 - x, y1 - y
                t = (gx * ey - gy * ex) / den
                s = (gx * uy - gy * ux) / den
                if 0.0 <= t <= best and 0.0 <= s <= 1.0 and t < best:
                    best = t
            readings.append(best)
        activation, offset = readings, 0
        for n_in, n_out in pairwise(sizes):
            bias = offset + n_in * n_out
            z = [genes[bias + j] for j in range(n_out)]
            for i in range(n_in):
                for j in range(n_out):
                    z[j] += activation[i] * genes[offset + i * n_out + j]
            activation = [1.0 / (1.0 + math.exp(-v)) for v in z]
            offset = bias + n_out
        steering = gain * (activation[1] - activation[0])
        c, s = math.cos(heading), math.sin(heading)
        nx, ny = -s * 0.5 * vehicle.width, c * 0.5 * vehicle.width
        rx, ry = x - vehicle.length * c, y - vehicle.length * s
        corners = [(x - nx, y - ny), (x + nx, y + ny), (rx + nx, ry + ny), (rx - nx, ry - ny)]
        for x1, y1, x2, y2 in walls:
            edges = any(
                _segments_intersect(*corners[i], *corners[(i + 1) % 4], x1, y1, x2, y2)
                for i in range(4)
            )
            if edges or _inside(x1, y1, corners):
                return steps, COLLIDED
        recent = (recent + [(x, y)])[-episode.spin_window :]
        if len(recent) == episode.spin_window:
            xs, ys = [p[0] for p in recent], [p[1] for p in recent]
            mx, my = sum(xs) / len(xs), sum(ys) / len(ys)
            vx = sum((v - mx) ** 2 for v in xs) / len(xs)
            vy = sum((v - my) ** 2 for v in ys) / len(ys)
            if vx <= episode.spin_variance and vy <= episode.spin_variance:
                return steps, SPUN
        if steps >= episode.max_steps:
            return steps, CAPPED
        half = 0.5 * vehicle.wheelbase
        rear_x, rear_y = x - half * c + distance * c, y - half * s + distance * s
        front_x = x + half * c + distance * math.cos(heading + steering)
        front_y = y + half * s + distance * math.sin(heading + steering)
        x, y = 0.5 * (front_x + rear_x), 0.5 * (front_y + rear_y)
        heading = math.atan2(front_y - rear_y, front_x - rear_x)
        steps += 1


def reference_wall_grid(walls: np.ndarray, reach: float, cell_size: float = 5.0
                        ) -> tuple[np.ndarray, np.ndarray]:
    """The wall grid's cell lists (``cell_start``, ``cell_walls`` of
    :class:`~enn_traffic.sim.sensors.WallGrid`) the obvious way, the oracle of their binning:
    the distance from every cell's centre to every wall, cells × walls."""
    low = np.minimum(walls[:, :2], walls[:, 2:]).min(axis=0) - reach
    high = np.maximum(walls[:, :2], walls[:, 2:]).max(axis=0) + reach
    nx, ny = np.ceil((high - low) / cell_size).astype(int)
    cx = low[0] + (np.arange(nx) + 0.5) * cell_size
    cy = low[1] + (np.arange(ny) + 0.5) * cell_size
    centres = np.stack(np.meshgrid(cx, cy, indexing="ij"), axis=-1).reshape(-1, 2)
    limit = reach + cell_size * math.sqrt(0.5)
    starts, members = [0], []
    for chunk in np.array_split(centres, max(1, len(centres) // 2048)):
        for row in point_segment_distance(chunk, walls) <= limit:
            members.append(np.flatnonzero(row))
            starts.append(starts[-1] + len(members[-1]))
    return np.asarray(starts, dtype=np.int64), np.concatenate(members).astype(np.int64)
