"""The rules of a step, written once (paper §4–§5.3; docs/design.md, "Units and the step").

Every loop that moves vehicles calls these compiled rules: the arena's life
(:mod:`enn_traffic.sim.arena`), the learner among SUMO's traffic in replay and closed loop
(:mod:`enn_traffic.sim.sumo.replay`) and many drivers at once (:mod:`enn_traffic.sim.crowd`). A step
is:

1. **blame** (:func:`responsible`): a vehicle is responsible for a collision if its body touches
   a wall or the body another vehicle had *before* the step (a vehicle that has just respawned
   has no such body);
2. **spin** (:func:`spun`): a vehicle whose positions over the last ``spin_window`` poses have
   variance at most ``spin_variance`` on both axes is spinning in place (fitness 0, §5.3);
3. **sense and decide** (:func:`~enn_traffic.sim.sensors.sense`, :func:`decide`): rangefinder
   readings of walls and of the other bodies, then the vehicle's network or scripted strategy
   gives its steering;
4. **move** (:func:`move_all`): the bicycle model, and the body that goes with the new pose;

and a vehicle that is responsible (other than the one being evaluated) **respawns**
(:func:`respawn`) at a free spot. Their constants travel in one :class:`Physics` (the numbers)
and one :class:`Geometry` (the arrays).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit

from enn_traffic.config.traffic import ACTION, NETWORK, NONE
from enn_traffic.core.geometry import (
    body_corners,
    body_hits_walls,
    box_hits_segment,
    box_hits_walls,
    boxes_overlap,
)
from enn_traffic.core.neural import network_buffers
from enn_traffic.core.neural import steering as network_steering
from enn_traffic.sim.bicycle import bicycle_step
from enn_traffic.sim.readings import (
    RANGE,
    beam_table,
    channel_codes,
    clear_seen,
    fill_channels,
    reading_count,
    seen_for,
)
from enn_traffic.sim.sensors import WallGrid, nearby_walls, sense, sense_walls_of
from enn_traffic.sim.strategies import (
    STRATEGY_FIELDS,
    next_uniform,
    reset_memory,
    scripted_steering,
    senses_vehicles,
)
from enn_traffic.sim.world import HIT_WALL, NO_HIT

# What the blame rule finds (:func:`responsible`), besides the index of a vehicle: HIT_WALL,
# NO_HIT (enn_traffic.sim.world).


# Every number a step needs, in the one form the compiled rules take (:data:`Physics`).
PHYSICS_FIELDS = [
    ("length", float),  # body, m
    ("width", float),
    ("wheelbase", float),
    ("distance", float),  # metres moved per step
    ("dt", float),  # seconds a step lasts
    ("radius", float),  # half diagonal of the largest body: farther apart, bodies cannot touch
    ("max_range", float),  # the longest beam's range, m: farther walls and bodies are not sensed
    ("gain", float),  # steering angle per unit of (left − right) network output, rad
    ("cell_x0", float),  # the wall grid: lower-left corner, cell size, cells along x and y
    ("cell_y0", float),
    ("cell_size", float),
    ("cells_x", int),
    ("cells_y", int),
    ("x_min", float),  # the drivable area's bounding box, where respawns are drawn
    ("y_min", float),
    ("x_max", float),
    ("y_max", float),
    ("spin_window", int),
    ("spin_variance", float),
    ("clearance", float),  # a respawned vehicle's least distance to every other
]
Physics = NamedTuple("Physics", PHYSICS_FIELDS + list(STRATEGY_FIELDS.items()))
Physics.__doc__ = """Every number a step needs, in the one form the compiled rules take: the
:data:`PHYSICS_FIELDS` and the scripted strategies' settings
(:data:`~enn_traffic.sim.strategies.STRATEGY_FIELDS`, so that a strategy's new setting is
written in its own module). Flat and numbers only: a compiled parallel loop cannot take a tuple
within a tuple, and a compiled function that takes an array out of a tuple it was given is many
times slower (the arrays travel in :class:`Geometry`). It also holds the wall grid's numbers
(:class:`~enn_traffic.sim.sensors.WallGrid`)."""


class Vehicles(NamedTuple):
    """The vehicles of one world, one row each (V): the pose, the body (corners, centre) now
    and before the step, whether the body is ``fresh`` (just respawned: nothing to blame
    against) and each one's strategy state for its life. The blame rule, the rangefinder, a
    move and a respawn read and write them."""

    pose: np.ndarray  # (V, 3) x, y, heading
    corners: np.ndarray  # (V, 4, 2)
    centres: np.ndarray  # (V, 2)
    previous: np.ndarray  # (V, 4, 2) the bodies before the step
    previous_centres: np.ndarray  # (V, 2)
    fresh: np.ndarray  # (V,) bool
    memory: np.ndarray  # (V, 2) the scripted strategies' state (enn_traffic.sim.strategies)


@njit(cache=True)
def vehicles_at(count: int) -> Vehicles:
    """Room for ``count`` vehicles (poses and bodies to be placed; none fresh)."""
    return Vehicles(np.empty((count, 3)), np.empty((count, 4, 2)), np.empty((count, 2)),
                    np.empty((count, 4, 2)), np.empty((count, 2)),
                    np.zeros(count, dtype=np.bool_), np.zeros((count, 2)))


class Work(NamedTuple):
    """A step's work arrays: one vehicle's readings and what its beams met
    (:func:`~enn_traffic.sim.readings.seen_for`), the networks' layer buffers
    (:func:`~enn_traffic.core.neural.network_buffers`) and every vehicle's steering (V,)."""

    readings: np.ndarray
    seen: np.ndarray | None
    activation: np.ndarray
    scratch: np.ndarray
    steering: np.ndarray


class Geometry(NamedTuple):
    """The arrays a step needs: the beams, walls, the wall grid's cells and the exits. The
    loops take them out by name once (``walls = geometry.walls``) and hand the rules the arrays
    themselves: a compiled call that takes a tuple of arrays is many times slower."""

    beams: np.ndarray  # the rangefinder's beams (enn_traffic.sim.readings.beam_table)
    channels: np.ndarray | None  # what each beam reads (readings.channel_codes; None: distances)
    walls: np.ndarray  # (S, 4)
    cell_start: np.ndarray  # the wall grid (WallGrid)
    cell_walls: np.ndarray
    all_walls: np.ndarray
    exits: np.ndarray  # (X, 4) segments that end a life as "left network"


@njit(cache=True)
def work_for(geometry, layer_sizes, count) -> Work:
    """A step's :class:`Work` arrays for ``count`` vehicles with the sensor of ``geometry``
    and networks of ``layer_sizes``."""
    activation, scratch = network_buffers(layer_sizes)
    return Work(np.empty(reading_count(geometry)), seen_for(geometry.beams, geometry.channels),
                activation, scratch, np.zeros(count))


@njit(cache=True, inline="always")
def remember_body(v, vehicles) -> None:
    """Vehicle ``v``'s body now becomes its body before the step. Element by element: an
    array assignment (``previous[v] = corners[v]``) makes numba compile its shape check's
    error message, seconds of every first compile (docs/bench.md, "First contact")."""
    previous, corners = vehicles.previous, vehicles.corners
    for c in range(corners.shape[1]):
        previous[v, c, 0] = corners[v, c, 0]
        previous[v, c, 1] = corners[v, c, 1]
    vehicles.previous_centres[v, 0] = vehicles.centres[v, 0]
    vehicles.previous_centres[v, 1] = vehicles.centres[v, 1]


@njit(cache=True, inline="always")
def remember_bodies(vehicles) -> None:
    """Every body now becomes its body before the step (:func:`remember_body`)."""
    for v in range(vehicles.corners.shape[0]):
        remember_body(v, vehicles)


@njit(cache=True, inline="always")
def copy_row(source, out) -> None:
    """``out[:] = source`` for 1-d arrays, element by element (:func:`remember_body`)."""
    for k in range(source.shape[0]):
        out[k] = source[k]


@njit(cache=True, inline="always")
def copy_rows(source, out) -> None:
    """``out[:] = source`` for 2-d arrays, element by element (:func:`remember_body`)."""
    for v in range(source.shape[0]):
        for k in range(source.shape[1]):
            out[v, k] = source[v, k]


@njit(cache=True, inline="always")
def wall_arrays(geometry):
    """The walls and the wall grid's arrays of ``geometry``, by name: what the per-vehicle
    rules (:func:`responsible`, :func:`~enn_traffic.sim.sensors.sense`) take."""
    return geometry.walls, geometry.cell_start, geometry.cell_walls, geometry.all_walls


def build_constants(grid: WallGrid, bounds, beams: list[tuple[float, float]],
                    channels: list[str], exits: np.ndarray, strategy: dict,
                    **numbers) -> tuple[Physics, Geometry]:
    """The :class:`Physics` and :class:`Geometry` of a world, from its wall grid, the drivable
    area's bounds, the beams (angle, range) of the scenario's rings and what each reads, the
    exits, the strategies' settings (:func:`~enn_traffic.sim.strategies.strategy_settings`)
    and the other numbers."""
    x_min, y_min, x_max, y_max = map(float, bounds)
    table = beam_table(beams)
    physics = Physics(max_range=float(table[:, RANGE].max()), cell_x0=grid.cell_x0,
                      cell_y0=grid.cell_y0, cell_size=grid.cell_size, cells_x=grid.cells_x,
                      cells_y=grid.cells_y, x_min=x_min, y_min=y_min, x_max=x_max, y_max=y_max,
                      **strategy, **numbers)
    geometry = Geometry(table, channel_codes(channels), grid.walls, grid.cell_start,
                        grid.cell_walls, grid.all_walls,
                        np.ascontiguousarray(exits, dtype=np.float64).reshape(-1, 4))
    return physics, geometry


@njit(cache=True, inline="always")
def place(v, x, y, heading, physics, pose, corners, centres):
    """Put vehicle ``v`` at (x, y, heading): its pose, body corners and body centre."""
    pose[v, 0], pose[v, 1], pose[v, 2] = x, y, heading
    body_corners(x, y, heading, physics.length, physics.width, corners[v])
    centres[v, 0] = 0.5 * (corners[v, 0, 0] + corners[v, 2, 0])
    centres[v, 1] = 0.5 * (corners[v, 0, 1] + corners[v, 2, 1])


@njit(cache=True)
def close(ax, ay, bx, by, near) -> bool:
    """Are body centres (ax, ay) and (bx, by) near enough for the bodies to touch? ``near``:
    the squared distance beyond which they cannot. (Numbers, not arrays: the rules' innermost
    loops call it, and a compiled call that takes arrays costs far more.)"""
    dx = ax - bx
    dy = ay - by
    return dx * dx + dy * dy <= near


@njit(cache=True, inline="always")
def responsible(v, pose, corners, centres, before, before_centres, absent, me, physics,
                walls, cell_start, cell_walls, all_walls) -> int:
    """The blame rule for vehicle ``v`` (``pose``, ``corners`` and ``centres`` hold its body):
    ``HIT_WALL`` if its body touches a wall, else the first vehicle of ``before`` (the bodies
    from before the step; ``absent`` ones and ``me``, its own, skipped) it touches, else
    ``NO_HIT``."""
    candidates = nearby_walls(pose[v, 0], pose[v, 1], physics, cell_start, cell_walls, all_walls)
    if body_hits_walls(corners[v], centres[v, 0], centres[v, 1], physics.radius, walls,
                       candidates):
        return HIT_WALL
    return hits_earlier_body(v, corners, centres, before, before_centres, absent, me,
                             4.0 * physics.radius * physics.radius)


@njit(cache=True, inline="always")
def hits_earlier_body(v, corners, centres, before, before_centres, absent, me, near) -> int:
    """The vehicles' half of the blame rule: the first body of ``before`` (``absent`` ones and
    ``me`` skipped) that vehicle ``v``'s body touches, else ``NO_HIT``. ``near``: the squared
    distance of body centres beyond which bodies cannot touch."""
    for other in range(before.shape[0]):
        if (other != me and not absent[other]
                and close(centres[v, 0], centres[v, 1], before_centres[other, 0],
                          before_centres[other, 1], near)
                and boxes_overlap(corners[v], before[other])):
            return other
    return NO_HIT


@njit(cache=True, inline="always")
def left_network(body, exits) -> bool:
    """Does the body touch an exit (the network's fringe, docs/sumo.md)?"""
    for e in range(exits.shape[0]):
        if box_hits_segment(body, exits[e, 0], exits[e, 1], exits[e, 2], exits[e, 3]):
            return True
    return False


@njit(cache=True, inline="always")
def spun(recent, life, x, y, spin_variance) -> bool:
    """Record (x, y) as step ``life`` of a life in the ring ``recent`` (window, 2); is the
    vehicle spinning in place: a full window whose x and y each vary by at most
    ``spin_variance``?"""
    window = recent.shape[0]
    slot = life % window
    recent[slot, 0], recent[slot, 1] = x, y
    return life + 1 >= window and _small_spread(recent, spin_variance)


@njit(cache=True, inline="always")
def _small_spread(points, limit) -> bool:
    """Population variance of x and of y both at most ``limit`` (y only when x's is)."""
    return _variance(points, 0) <= limit and _variance(points, 1) <= limit


@njit(cache=True, inline="always")
def _variance(points, axis) -> float:
    """Population variance of column ``axis``: the sums in the order an array expression
    takes them, without the temporary arrays it builds on every step."""
    n = points.shape[0]
    total = 0.0
    for k in range(n):
        total += points[k, axis]
    mean = total / n
    spread = 0.0
    for k in range(n):
        spread += (points[k, axis] - mean) ** 2
    return spread / n


@njit(cache=True, inline="always")
def decide(v, kind, genes, layer_sizes, readings, physics, beams, memory, rng,
           activation, scratch):
    """The steering angle of vehicle ``v``, driven by ``kind``: its network (``genes[v]``,
    source layout) or its scripted strategy (``memory[v]``: the strategy's state for this
    life). Each row is taken in the branch that reads it: a row taken on every step, read or
    not, cost 2% of the navigation step's instructions."""
    if kind == NETWORK:
        return network_steering(genes[v], layer_sizes, readings, activation, scratch,
                                physics.gain)
    if kind != NONE:
        return scripted_steering(kind, readings, beams, physics, memory[v], rng)
    return 0.0


@njit(cache=True, inline="always")
def drive_all(kinds, genes, layer_sizes, physics, geometry, vehicles, rng, work):
    """Every vehicle senses and decides (``genes[v]`` for a network driver; an ``ACTION``
    vehicle keeps the ``work.steering[v]`` it was given), then all move at once: the bodies
    before the move become ``previous``, and no body is ``fresh`` any more."""
    pose, corners, centres, memory = (vehicles.pose, vehicles.corners, vehicles.centres,
                                      vehicles.memory)
    readings, activation, scratch, steering = (work.readings, work.activation, work.scratch,
                                               work.steering)
    beams, channels, before = geometry.beams, geometry.channels, vehicles.previous_centres
    walls, cell_start, cell_walls, all_walls = wall_arrays(geometry)
    count = pose.shape[0]
    for v in range(count):
        kind = kinds[v]
        if kind == ACTION:
            continue
        if kind != NONE:
            sense(v, pose, physics, beams, channels, walls, cell_start, cell_walls, all_walls,
                  count > 1 and senses_vehicles(kind, physics), corners, centres, before, v,
                  readings, work.seen)
        steering[v] = decide(v, kind, genes, layer_sizes, readings, physics, beams, memory, rng,
                             activation, scratch)
    move_all(steering, physics, vehicles)


@njit(cache=True, inline="always")
def drive_alone(genes, layer_sizes, physics, geometry, vehicles, work):
    """:func:`drive_all` for vehicle 0 alone, driven by its network (``genes[0]``): a kernel
    that calls it in place of :func:`drive_all` compiles without the traffic's rules
    (:func:`enn_traffic.sim.arena.alone`)."""
    walls, cell_start, cell_walls, all_walls = wall_arrays(geometry)
    beams, channels = geometry.beams, geometry.channels
    _, _, cos_h, sin_h = sense_walls_of(0, vehicles.pose, physics, beams, walls, cell_start,
                                        cell_walls, all_walls, work.readings)
    clear_seen(work.seen)
    fill_channels(channels, beams, work.seen, cos_h, sin_h, physics.distance / physics.dt,
                  work.readings)
    work.steering[0] = network_steering(genes[0], layer_sizes, work.readings, work.activation,
                                        work.scratch, physics.gain)
    move_all(work.steering, physics, vehicles)


@njit(cache=True, inline="always")
def move_all(steering, physics, vehicles):
    """Every vehicle moves one step by the bicycle model (paper §4)."""
    pose, corners, centres = vehicles.pose, vehicles.corners, vehicles.centres
    remember_bodies(vehicles)
    vehicles.fresh[:] = False
    for v in range(pose.shape[0]):
        x, y, heading = bicycle_step(pose[v, 0], pose[v, 1], pose[v, 2], steering[v],
                                     physics.distance, physics.wheelbase)
        place(v, x, y, heading, physics, pose, corners, centres)


@njit(cache=True)
def respawn(v, kind, physics, geometry, vehicles, rng) -> bool:
    """Move vehicle ``v`` to a random free pose with a fresh life: on the drivable area,
    touching no wall, at least ``clearance`` from every other vehicle, with no earlier body to
    blame against and its strategy's state reset. False (nothing changed) if no such pose
    was found in 200 draws."""
    trial = np.empty((4, 2))
    for _ in range(200):
        x = physics.x_min + (physics.x_max - physics.x_min) * next_uniform(rng)
        y = physics.y_min + (physics.y_max - physics.y_min) * next_uniform(rng)
        heading = math.pi * (2.0 * next_uniform(rng) - 1.0)
        if not inside(x, y, geometry.walls):
            continue
        if _enter_if_free(v, x, y, heading, kind, physics, geometry, vehicles, rng, trial):
            return True
    return False


@njit(cache=True)
def respawn_on_lanes(v, kind, spots, clear_of_walls, physics, geometry, vehicles, rng) -> bool:
    """:func:`respawn` at one of ``spots`` (S, 3: x, y, heading along the lanes, facing their
    traffic): a network's roads can fill little of its bounding box. ``clear_of_walls`` (S,
    int8) remembers, per spot, whether a body there touches no wall (1), touches one (0) or
    is not known yet (-1): walls stay put, and the test against them costs a pass over every
    wall (:func:`inside`)."""
    trial = np.empty((4, 2))
    for _ in range(200):
        spot = min(int(next_uniform(rng) * spots.shape[0]), spots.shape[0] - 1)
        x, y, heading = spots[spot, 0], spots[spot, 1], spots[spot, 2]
        if clear_of_walls[spot] < 0:
            clear_of_walls[spot] = clear_of_walls_at(x, y, heading, physics, geometry, trial)
        if clear_of_walls[spot] and clear_of_vehicles(v, x, y, physics, vehicles.pose):
            enter(v, x, y, heading, kind, physics, vehicles, rng)
            return True
    return False


@njit(cache=True)
def _enter_if_free(v, x, y, heading, kind, physics, geometry, vehicles, rng, trial) -> bool:
    """Place vehicle ``v`` at (x, y, heading) with a fresh life if its body there touches no
    wall, its rear is on the area and every other vehicle is ``clearance`` away."""
    if not clear_of_walls_at(x, y, heading, physics, geometry, trial):
        return False
    if not clear_of_vehicles(v, x, y, physics, vehicles.pose):
        return False
    enter(v, x, y, heading, kind, physics, vehicles, rng)
    return True


@njit(cache=True, inline="always")
def clear_of_walls_at(x, y, heading, physics, geometry, trial) -> bool:
    """Does a body at (x, y, heading) touch no wall, its rear on the area? (``trial``: (4, 2)
    work array, left holding the body's corners)"""
    walls = geometry.walls
    body_corners(x, y, heading, physics.length, physics.width, trial)
    candidates = nearby_walls(x, y, physics, geometry.cell_start, geometry.cell_walls,
                              geometry.all_walls)
    if box_hits_walls(trial, walls, candidates, candidates.shape[0]):
        return False
    return inside(trial[2, 0], trial[2, 1], walls)


@njit(cache=True, inline="always")
def clear_of_vehicles(v, x, y, physics, pose) -> bool:
    """Is every vehicle but ``v`` at least ``clearance`` from (x, y)?"""
    for other in range(pose.shape[0]):
        if other != v and closer_than(x - pose[other, 0], y - pose[other, 1],
                                      physics.clearance):
            return False
    return True


@njit(cache=True, inline="always")
def closer_than(dx, dy, reach) -> bool:
    """``hypot(dx, dy) < reach``, the hypot computed only where neither leg exceeds ``reach``
    (exact: a faithful hypot is never below its larger leg)."""
    return abs(dx) <= reach and abs(dy) <= reach and math.hypot(dx, dy) < reach


@njit(cache=True, inline="always")
def enter(v, x, y, heading, kind, physics, vehicles, rng) -> None:
    """Vehicle ``v`` starts a fresh life at (x, y, heading): no earlier body to blame against,
    its strategy's state reset."""
    place(v, x, y, heading, physics, vehicles.pose, vehicles.corners, vehicles.centres)
    remember_body(v, vehicles)
    vehicles.fresh[v] = True
    reset_memory(kind, physics, rng, vehicles.memory[v])


@njit(cache=True)
def inside(x, y, walls) -> bool:
    """Is (x, y) inside the area the closed wall rings bound? (crossing number)"""
    result = False
    for w in range(walls.shape[0]):
        x1, y1, x2, y2 = walls[w, 0], walls[w, 1], walls[w, 2], walls[w, 3]
        if (y1 > y) != (y2 > y) and x < x1 + (y - y1) * (x2 - x1) / (y2 - y1):
            result = not result
    return result


@njit(cache=True, inline="always")
def within_range(x, y, centres, first, reach) -> int:
    """How many of ``centres[first:]`` lie within ``reach`` of (x, y) (traffic met)."""
    count = 0
    for v in range(first, centres.shape[0]):
        if (centres[v, 0] - x) ** 2 + (centres[v, 1] - y) ** 2 <= reach * reach:
            count += 1
    return count


@njit(cache=True)
def life_columns(size):
    """Per world of a batch: steps, outcome, collisions suffered, vehicle-steps within sensor
    range, most within range at once (zeros, to be filled), and what the learner hit
    (``NO_HIT``, to be filled: ``HIT_WALL`` or the vehicle)."""
    return (np.zeros(size, dtype=np.int64), np.zeros(size, dtype=np.int64),
            np.zeros(size, dtype=np.int64), np.zeros(size, dtype=np.int64),
            np.zeros(size, dtype=np.int64), np.full(size, NO_HIT, dtype=np.int64))
