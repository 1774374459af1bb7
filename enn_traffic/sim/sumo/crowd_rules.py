"""The compiled rules of several learners in a live SUMO (:mod:`enn_traffic.sim.sumo.crowd`):
the blame rule, exits and spins of every learner at a step (:func:`learner_events`), every
learner sensing, counting its 2-D conflicts, deciding and moving (:func:`drive`), and a
learner re-entering at a free spot (:func:`reenter`).

The blame rule is the arena's and the closed loop's (:mod:`enn_traffic.sim.rules`,
:mod:`enn_traffic.sim.sumo.replay`):

- a learner whose body touches a wall, the body a SUMO vehicle had before the step, or the
  body another learner had before the step is responsible: its life ends and it re-enters at
  a free spot of the network (no wall, no vehicle within ``respawn_clearance``);
- a SUMO vehicle whose body touches a learner's body from before the step is responsible: the
  learner suffers the collision and the vehicle leaves that learner's world, as in the closed
  loop with one learner (it stays in SUMO and in the other learners' worlds);
- a learner that reaches an exit of the network has left it, and re-enters as after a
  collision; learners are held to §5.3's spin test.

Each learner looks only at the bodies in the cells around it (:mod:`enn_traffic.sim.buckets`),
so a step costs learners + vehicles, not learners × vehicles.
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit

from enn_traffic.core.neural import steering as network_steering
from enn_traffic.sim.buckets import Buckets, buckets_for, fill, nearby
from enn_traffic.sim.crowd import ALIVE
from enn_traffic.sim.readings import clear_seen, fill_channels, seen_for
from enn_traffic.sim.rules import (
    NO_HIT,
    closer_than,
    hits_earlier_body,
    left_network,
    move_all,
    respawn_on_lanes,
    responsible,
    spun,
    wall_arrays,
)
from enn_traffic.sim.safety import CONFLICT_TTC, least_time_among
from enn_traffic.sim.sensors import sense_bodies, sense_walls_of
from enn_traffic.sim.sumo.replay import (
    in_world,
    mark_absent,
    struck_by_traffic,
    visible_centres,
)
from enn_traffic.sim.world import COLLIDED, LEFT_NETWORK, SPUN


class Near(NamedTuple):
    """Work arrays: the bodies near one learner, gathered from their buckets (N rows)."""

    index: np.ndarray  # (N,) int64 their rows in the whole arrays
    ids: np.ndarray  # (N,) int64 SUMO's ids (slots)
    corners: np.ndarray  # (N, 4, 2)
    centres: np.ndarray  # (N, 2)
    gone: np.ndarray  # (N,) int64 the learner's ``gone`` (slots)
    absent: np.ndarray  # (N,) bool not in the learner's world (before the step, for blame)
    visible: np.ndarray  # (N, 2) the centres the learner sees (slots)
    before: np.ndarray  # (N, 2) the centres a step before, when the beams read motion
    velocity: np.ndarray  # (N, 2) m/s, for the 2-D time to collision


def near_for(rows: int) -> Near:
    """Room for ``rows`` bodies."""
    return Near(np.zeros(rows, dtype=np.int64), np.zeros(rows, dtype=np.int64),
                np.zeros((rows, 4, 2)), np.zeros((rows, 2)), np.zeros(rows, dtype=np.int64),
                np.zeros(rows, dtype=np.bool_), np.zeros((rows, 2)), np.zeros((rows, 2)),
                np.zeros((rows, 2)))


class Learners(NamedTuple):
    """The learners' lives, one row each (K), their worlds, one entry per SUMO slot (S), and
    the buckets of the bodies around them."""

    life: np.ndarray  # (K,) steps lived
    recent: np.ndarray  # (K, spin_window, 2) positions for the spin test
    spin_checked: np.ndarray  # (K,) bool
    active: np.ndarray  # (K,) bool; False: left the network for good
    suffered: np.ndarray  # (K,) collisions SUMO vehicles caused
    events: np.ndarray  # (K,) ALIVE, or what ended the life at this step
    gone: np.ndarray  # (K, S) the id a slot held when it left learner k's world, or -1
    closing: np.ndarray  # (K,) bool its 2-D time to collision below CONFLICT_TTC last step
    conflicts: np.ndarray  # (K,) times it came below CONFLICT_TTC (2-D conflicts)
    slot_buckets: tuple[Buckets, Buckets]  # SUMO's bodies, one per row of the slot arrays
    learner_buckets: Buckets  # the learners' bodies
    near_slots: Near  # (S rows) work arrays
    near_learners: Near  # (K rows) work arrays


def learners_for(count: int, spin_window: int, slots: int) -> Learners:
    """``count`` learners at the start of their lives, alive and active, with room for
    ``slots`` SUMO slots."""
    return Learners(
        np.zeros(count, dtype=np.int64), np.zeros((count, spin_window, 2)),
        np.ones(count, dtype=np.bool_), np.ones(count, dtype=np.bool_),
        np.zeros(count, dtype=np.int64), np.full(count, ALIVE, dtype=np.int64),
        np.full((count, slots), -1, dtype=np.int64), np.zeros(count, dtype=np.bool_),
        np.zeros(count, dtype=np.int64), (buckets_for(slots), buckets_for(slots)),
        buckets_for(count), near_for(slots), near_for(count))


@njit(cache=True, inline="always")
def reach(physics) -> float:
    """The side of the buckets' cells: at least as far as a learner senses a body (its longest
    beam and a body's bounding radius) and as bodies that touch lie apart."""
    farthest = max(physics.max_range + physics.radius, 2.0 * physics.radius)
    return farthest * (1.0 + 1e-9) + 1e-6


@njit(cache=True)
def fill_slots(learners, physics, slots, row) -> None:
    """Bucket SUMO's bodies of ``row`` of the slot arrays."""
    ids, _, centres = slots
    fill(learners.slot_buckets[row], centres[row], ids[row] >= 0, reach(physics))


@njit(cache=True, inline="always")
def gather_slots(learners, k, x, y, slots, row) -> int:
    """SUMO's bodies of ``row`` in the cells around (x, y), with learner ``k``'s ``gone``,
    into ``learners.near_slots``: how many."""
    ids, corners, centres = slots
    near, gone = learners.near_slots, learners.gone[k]
    n = nearby(learners.slot_buckets[row], x, y, near.index)
    for i in range(n):
        s = near.index[i]
        near.ids[i], near.gone[i] = ids[row, s], gone[s]
        near.centres[i, 0], near.centres[i, 1] = centres[row, s, 0], centres[row, s, 1]
        for c in range(4):
            near.corners[i, c, 0], near.corners[i, c, 1] = (corners[row, s, c, 0],
                                                            corners[row, s, c, 1])
    return n


@njit(cache=True, inline="always")
def gather_learners(learners, k, x, y, corners, centres):
    """The learners' bodies (``corners``, ``centres``) in the cells around (x, y) into
    ``learners.near_learners``: how many, and learner ``k``'s row there (-1 if not among
    them)."""
    near = learners.near_learners
    n = nearby(learners.learner_buckets, x, y, near.index)
    me = -1
    for i in range(n):
        other = near.index[i]
        if other == k:
            me = i
        near.centres[i, 0], near.centres[i, 1] = centres[other, 0], centres[other, 1]
        for c in range(4):
            near.corners[i, c, 0], near.corners[i, c, 1] = (corners[other, c, 0],
                                                            corners[other, c, 1])
    return n, me


@njit(cache=True)
def learner_events(t, vehicles, learners, physics, geometry, slots, before, now) -> bool:
    """Fill ``learners.events``: ``COLLIDED`` for an ``active`` learner responsible for a
    collision, ``LEFT_NETWORK`` at an exit, ``SPUN`` for a spin, else ``ALIVE``; count the
    collisions SUMO vehicles cause (``suffered``) and take those vehicles out of the learner's
    world (``gone[k]``). ``slots``: SUMO's (ids, corners, centres), rows ``before`` and
    ``now``. Did any life end?"""
    pose, body, centre = vehicles.pose, vehicles.corners, vehicles.centres
    events, gone, near = learners.events, learners.gone, learners.near_slots
    others = learners.near_learners
    exits = geometry.exits
    walls, cell_start, cell_walls, all_walls = wall_arrays(geometry)
    touch = 4.0 * physics.radius * physics.radius
    fill_slots(learners, physics, slots, before)
    fill_slots(learners, physics, slots, now)
    fill(learners.learner_buckets, vehicles.previous_centres, ~vehicles.fresh, reach(physics))
    ended = False
    for k in range(pose.shape[0]):
        events[k] = ALIVE
        if not learners.active[k]:
            continue
        if left_network(body[k], exits):
            events[k] = LEFT_NETWORK
            ended = True
            continue
        n = gather_slots(learners, k, centre[k, 0], centre[k, 1], slots, before)
        mark_absent(t, near.ids[:n], near.gone[:n], near.absent[:n])
        m, me = gather_learners(learners, k, centre[k, 0], centre[k, 1], vehicles.previous,
                                vehicles.previous_centres)
        for i in range(m):
            others.absent[i] = vehicles.fresh[others.index[i]]
        if (responsible(k, pose, body, centre, near.corners[:n], near.centres[:n],
                        near.absent[:n], -1, physics, walls, cell_start, cell_walls,
                        all_walls) != NO_HIT
                or hits_earlier_body(k, body, centre, others.corners[:m], others.centres[:m],
                                     others.absent[:m], me, touch) != NO_HIT):
            events[k] = COLLIDED
            ended = True
            continue
        if t > 0 and not vehicles.fresh[k]:
            n = gather_slots(learners, k, vehicles.previous_centres[k, 0],
                             vehicles.previous_centres[k, 1], slots, now)
            learners.suffered[k] += struck_by_traffic(k, vehicles.previous,
                                                      vehicles.previous_centres, near.ids[:n],
                                                      near.corners[:n], near.centres[:n],
                                                      near.gone[:n], touch)
            for i in range(n):
                gone[k, near.index[i]] = near.gone[i]
        if learners.spin_checked[k] and spun(learners.recent[k], learners.life[k], pose[k, 0],
                                             pose[k, 1], physics.spin_variance):
            events[k] = SPUN
            ended = True
    return ended


@njit(cache=True, inline="always")
def fill_now(physics, slots, now, vehicles, learners) -> None:
    """Bucket SUMO's bodies now and the learners' bodies, for :func:`sense_learner`."""
    fill_slots(learners, physics, slots, now)
    fill(learners.learner_buckets, vehicles.centres, learners.active, reach(physics))


@njit(cache=True, inline="always")
def sense_learner(k, physics, geometry, slots, now, vehicles, learners, readings,
                  seen) -> tuple[int, int, int]:
    """Learner ``k`` senses the walls, the SUMO vehicles in its world and the other
    learners into ``readings`` (the buckets filled by :func:`fill_now`): the steps of
    :func:`~enn_traffic.sim.sensors.sense`, with two groups of bodies. Returns how many of
    each group it gathered, and its own row among the learners (-1 if not among them)."""
    pose, near, others = vehicles.pose, learners.near_slots, learners.near_learners
    x, y = pose[k, 0], pose[k, 1]
    beams, channels = geometry.beams, geometry.channels
    walls, cell_start, cell_walls, all_walls = wall_arrays(geometry)
    n = gather_slots(learners, k, x, y, slots, now)
    visible_centres(near.ids[:n], near.centres[:n], near.gone[:n], near.visible[:n])
    m, me = gather_learners(learners, k, x, y, vehicles.corners, vehicles.centres)
    gather_motion(slots, now, vehicles.previous_centres, near, n, others, m)
    x, y, cos_h, sin_h = sense_walls_of(k, pose, physics, beams, walls, cell_start, cell_walls,
                                        all_walls, readings)
    clear_seen(seen)
    radius, dt = physics.radius, physics.dt
    sense_bodies(-1, x, y, cos_h, sin_h, beams, near.corners[:n], near.visible[:n],
                 near.before[:n], radius, dt, readings, seen)
    sense_bodies(me, x, y, cos_h, sin_h, beams, others.corners[:m], others.centres[:m],
                 others.before[:m], radius, dt, readings, seen)
    fill_channels(channels, beams, seen, cos_h, sin_h, physics.distance / physics.dt, readings)
    return n, m, me


@njit(cache=True, inline="always")
def count_conflict(k, physics, vehicles, learners, n, m, me) -> None:
    """Learner ``k``'s 2-D time to collision (:mod:`~enn_traffic.sim.safety`) with the bodies
    :func:`sense_learner` gathered: SUMO's vehicles in its world, each moving as it did in the
    last step, and the other learners, each at its speed along its heading (its own motion):
    a conflict each time it comes below :data:`~enn_traffic.sim.safety.CONFLICT_TTC`."""
    near, others = learners.near_slots, learners.near_learners
    for i in range(n):
        near.absent[i] = not in_world(near.ids, near.gone, i)
        near.velocity[i, 0] = (near.centres[i, 0] - near.before[i, 0]) / physics.dt
        near.velocity[i, 1] = (near.centres[i, 1] - near.before[i, 1]) / physics.dt
    speed = physics.distance / physics.dt
    for i in range(m):
        others.absent[i] = i == me
        heading = vehicles.pose[others.index[i], 2]
        others.velocity[i, 0], others.velocity[i, 1] = (speed * math.cos(heading),
                                                        speed * math.sin(heading))
    heading = vehicles.pose[k, 2]
    vx, vy = speed * math.cos(heading), speed * math.sin(heading)
    corners, gap = vehicles.corners[k], 2.0 * physics.radius
    least = min(least_time_among(corners, vx, vy, near.corners[:n], near.centres[:n],
                                 near.velocity[:n], near.absent[:n], gap, CONFLICT_TTC),
                least_time_among(corners, vx, vy, others.corners[:m], others.centres[:m],
                                 others.velocity[:m], others.absent[:m], gap, CONFLICT_TTC))
    closing = least < CONFLICT_TTC
    if closing and not learners.closing[k]:
        learners.conflicts[k] += 1
    learners.closing[k] = closing


@njit(cache=True, inline="always")
def gather_motion(slots, now, previous_centres, near, n, others, m) -> None:
    """The centres a step before of the gathered bodies, what the beams' further channels
    read motion from: a SUMO vehicle's in the slot arrays' other row (its centre now when it
    was not in the slot then), a learner's previous centre."""
    ids, _, centres = slots
    before = 1 - now  # the slot arrays hold two rows: the step before and now
    for i in range(n):
        s = near.index[i]
        row = before if ids[before, s] == ids[now, s] else now
        near.before[i, 0], near.before[i, 1] = centres[row, s, 0], centres[row, s, 1]
    for i in range(m):
        other = others.index[i]
        others.before[i, 0] = previous_centres[other, 0]
        others.before[i, 1] = previous_centres[other, 1]


@njit(cache=True, inline="always")
def move(steering, physics, vehicles, learners) -> None:
    """All learners move at once, each by its ``steering``."""
    move_all(steering, physics, vehicles)
    learners.life[:] += 1


@njit(cache=True)
def drive(genes, layer_sizes, physics, geometry, slots, now, vehicles, learners, work) -> None:
    """Every learner senses (:func:`sense_learner`) and counts its 2-D conflicts
    (:func:`count_conflict`), its network (``genes[k]``) steers, and all move at once."""
    fill_now(physics, slots, now, vehicles, learners)
    for k in range(vehicles.pose.shape[0]):
        n, m, me = sense_learner(k, physics, geometry, slots, now, vehicles, learners,
                                 work.readings, work.seen)
        if learners.active[k]:
            count_conflict(k, physics, vehicles, learners, n, m, me)
        work.steering[k] = network_steering(genes[k], layer_sizes, work.readings,
                                            work.activation, work.scratch, physics.gain)
    move(work.steering, physics, vehicles, learners)


@njit(cache=True)
def observe(physics, geometry, slots, now, vehicles, learners, out) -> None:
    """Every ``active`` learner ``k`` senses into ``out[k]`` (for a caller that steers them
    from outside: the PettingZoo SUMO crowd, :mod:`enn_traffic.envs.sumo`)."""
    fill_now(physics, slots, now, vehicles, learners)
    seen = seen_for(geometry.beams, geometry.channels)
    for k in range(vehicles.pose.shape[0]):
        if learners.active[k]:
            sense_learner(k, physics, geometry, slots, now, vehicles, learners, out[k], seen)


move_once = njit(cache=True)(move.py_func)


@njit(cache=True)
def reenter(entering, kind, spots, clear_of_walls, physics, geometry, vehicles, rng, centres,
            ids, tries) -> int:
    """The learners ``entering`` (rows of ``vehicles``, the learners; in order) start new
    lives, each at one of ``spots`` (:func:`~enn_traffic.sim.rules.respawn_on_lanes`, which
    ``clear_of_walls`` serves): the first of ``tries`` drawn that is ``clearance`` from every
    SUMO vehicle (``centres`` of the slots whose ``ids`` are not negative), else the last
    drawn. Returns how many entered: fewer when no spot free of walls and learners was
    found for the next one."""
    for done in range(entering.shape[0]):
        k = entering[done]
        for _ in range(tries):
            if not respawn_on_lanes(k, kind, spots, clear_of_walls, physics, geometry,
                                    vehicles, rng):
                return done
            if clear_of_slots(vehicles.centres[k, 0], vehicles.centres[k, 1], centres, ids,
                              physics.clearance):
                break
    return entering.shape[0]


@njit(cache=True, inline="always")
def clear_of_slots(x, y, centres, ids, clearance) -> bool:
    """Is every SUMO vehicle (``centres`` of the slots whose ``ids`` are not negative) at
    least ``clearance`` from (x, y)?"""
    for slot in range(ids.shape[0]):
        if ids[slot] >= 0 and closer_than(centres[slot, 0] - x, centres[slot, 1] - y,
                                          clearance):
            return False
    return True
