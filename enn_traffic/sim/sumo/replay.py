"""The learner among traffic it does not steer, given as bodies step by step (docs/sumo.md).

The traffic comes from SUMO: recorded once per traffic seed and replayed to every world of a
generation (replay mode), or read from a live SUMO after each step (closed-loop mode, where
SUMO also sees the learner). Both modes run the same compiled step, :func:`learner_step`, so
they agree wherever the traffic does not react to the learner, and it applies the arena's
rules (:mod:`enn_traffic.sim.rules`).

Traffic at step ``t`` is a set of slots: ``ids[t]`` (S,) the vehicle in each slot (-1: empty),
``corners[t]`` (S, 4, 2) its body and ``centres[t]`` (S, 2) the body's centre. The blame rule
is the arena's (paper §5.3): the learner is responsible if its body touches a wall or a
vehicle's body from before the step; a vehicle whose body touches the learner's body from
before the step is responsible, counts as a collision the learner suffered, and leaves this
world (``gone``), as an arena vehicle respawns. Vehicles within
``respawn_clearance`` of the learner's start leave the world before the first step. A learner
whose body touches an exit (the network's fringe, docs/sumo.md) has left the network.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numba
import numpy as np
from numba import njit, prange

from enn_traffic.core.geometry import boxes_overlap
from enn_traffic.core.neural import steering as network_steering
from enn_traffic.sim.readings import channel_count
from enn_traffic.sim.rules import (
    HIT_WALL,
    NO_HIT,
    Vehicles,
    Work,
    close,
    copy_row,
    left_network,
    life_columns,
    move_all,
    place,
    remember_bodies,
    responsible,
    spun,
    vehicles_at,
    wall_arrays,
    within_range,
    work_for,
)
from enn_traffic.sim.sensors import sense
from enn_traffic.sim.world import CAPPED, COLLIDED, LEFT_NETWORK, RUNNING, SPUN
from enn_traffic.sumo.simulation import FAR


@njit(cache=True)
def in_world(ids, gone, s) -> bool:
    """Is the vehicle in slot ``s`` on the network and in the learner's world (not
    ``gone``)?"""
    return ids[s] >= 0 and ids[s] != gone[s]


@njit(cache=True, inline="always")
def mark_absent(t, ids_before, gone, absent) -> None:
    """``absent[s]``: slot ``s`` held no body in the learner's world before the step (nothing
    did at step 0)."""
    for s in range(ids_before.shape[0]):
        absent[s] = t == 0 or not in_world(ids_before, gone, s)


@njit(cache=True, inline="always")
def struck_by_traffic(v, body_before, centre_before, ids_now, corners_now, centres_now, gone,
                      near) -> int:
    """The traffic's half of the blame rule: every vehicle whose body now touches learner
    ``v``'s body from before the step is responsible and leaves the learner's world
    (``gone``). How many did?"""
    struck = 0
    for s in range(ids_now.shape[0]):
        if (in_world(ids_now, gone, s)
                and close(centres_now[s, 0], centres_now[s, 1], centre_before[v, 0],
                          centre_before[v, 1], near)
                and boxes_overlap(corners_now[s], body_before[v])):
            gone[s] = ids_now[s]
            struck += 1
    return struck


@njit(cache=True, inline="always")
def visible_centres(ids_now, centres_now, gone, visible) -> None:
    """The centres the learner sees: those of the vehicles in its world, the others far
    off."""
    for s in range(ids_now.shape[0]):
        if in_world(ids_now, gone, s):
            visible[s, 0], visible[s, 1] = centres_now[s, 0], centres_now[s, 1]
        else:
            visible[s, 0], visible[s, 1] = FAR, FAR


@njit(cache=True, inline="always")
def moved_from(ids_before, ids_now, centres_before, centres_now, out) -> None:
    """Where each slot's vehicle was a step before, what a beam's further channels read its
    motion from: its centre then, or now (no motion) when it was not in the slot then."""
    for s in range(ids_now.shape[0]):
        source = centres_before if ids_before[s] == ids_now[s] else centres_now
        out[s, 0], out[s, 1] = source[s, 0], source[s, 1]


@njit(cache=True)
def clear_start(centre, ids, centres, gone, clearance) -> None:
    """Take vehicles within ``clearance`` of the learner's body centre out of the world."""
    for s in range(ids.shape[0]):
        if (ids[s] >= 0 and math.hypot(centres[s, 0] - centre[0, 0],
                                       centres[s, 1] - centre[0, 1]) < clearance):
            gone[s] = ids[s]


class LearnerState(NamedTuple):
    """One life's arrays for :func:`learner_step`: the learner as a world of one vehicle
    (never fresh: it does not respawn), its work arrays, what it has met, and one entry per
    traffic slot."""

    learner: Vehicles  # one row
    work: Work  # its readings, network buffers and steering (1,)
    recent: np.ndarray  # (spin_window, 2) positions for the spin test
    suffered: np.ndarray  # (1,) collisions suffered
    met: np.ndarray  # (2,) vehicle-steps within sensor range, most at once
    gone: np.ndarray  # (S,) the id a slot held when it left the learner's world, or -1
    visible: np.ndarray  # (S, 2) the centres the learner sees (far off: not seen)
    moved: np.ndarray  # (S, 2) the centres a step before, when the beams read motion
    absent: np.ndarray  # (S,) not in the learner's world before the step
    hit: np.ndarray  # (1,) what the learner ran into: NO_HIT, HIT_WALL or the vehicle's id


@njit(cache=True)
def learner_state(start, physics, geometry, layer_sizes, slots) -> LearnerState:
    """A fresh :class:`LearnerState` at pose ``start`` among ``slots`` traffic slots."""
    learner = vehicles_at(1)
    place(0, start[0], start[1], start[2], physics, learner.pose, learner.corners,
          learner.centres)
    remember_bodies(learner)
    return LearnerState(learner, work_for(geometry, layer_sizes, 1),
                        np.empty((physics.spin_window, 2)), np.zeros(1, np.int64),
                        np.zeros(2, np.int64), np.full(slots, -1, np.int64),
                        np.empty((slots, 2)), np.empty((slots, 2)), np.empty(slots, np.bool_),
                        np.full(1, NO_HIT, np.int64))


def with_slots(state: LearnerState, slots: int) -> LearnerState:
    """``state`` with room for ``slots`` traffic slots (the new ones never gone)."""
    gone = np.full(slots, -1, dtype=np.int64)
    gone[: len(state.gone)] = state.gone
    return state._replace(gone=gone, visible=np.empty((slots, 2)), moved=np.empty((slots, 2)),
                          absent=np.empty(slots, np.bool_))


@njit(cache=True, inline="always")
def learner_sense(t, physics, geometry, ids, corners, centres, before, now, max_steps, state):
    """Steps 0–3 of :func:`learner_step`, before the learner decides: the fringe, collisions,
    spin test and step cap, then the learner senses into ``state.work.readings``. Returns an
    outcome code, or ``RUNNING``."""
    learner, gone, met = state.learner, state.gone, state.met
    beams, exits = geometry.beams, geometry.exits
    walls, cell_start, cell_walls, all_walls = wall_arrays(geometry)
    pose, body = learner.pose, learner.corners
    ids_before, corners_before, centres_before = ids[before], corners[before], centres[before]
    ids_now, corners_now, centres_now = ids[now], corners[now], centres[now]
    # 0. the fringe: an exit reached ends the life, whatever else the body touches
    if left_network(body[0], exits):
        return LEFT_NETWORK
    # 1. collisions by the blame rule
    mark_absent(t, ids_before, gone, state.absent)
    found = responsible(0, pose, body, learner.centres, corners_before, centres_before,
                        state.absent, -1, physics, walls, cell_start, cell_walls, all_walls)
    if found != NO_HIT:
        state.hit[0] = found if found == HIT_WALL else ids_before[found]
        return COLLIDED
    if t > 0:
        state.suffered[0] += struck_by_traffic(0, learner.previous, learner.previous_centres,
                                               ids_now, corners_now, centres_now, gone,
                                               4.0 * physics.radius * physics.radius)
    # 2. spin test and step cap
    if spun(state.recent, t, pose[0, 0], pose[0, 1], physics.spin_variance):
        return SPUN
    if t >= max_steps:
        return CAPPED
    # 3. sense walls and the visible vehicles
    visible = state.visible
    visible_centres(ids_now, centres_now, gone, visible)
    within = within_range(pose[0, 0], pose[0, 1], visible, 0, physics.max_range + physics.radius)
    met[0] += within
    met[1] = max(met[1], within)
    channels, moved = geometry.channels, state.moved
    if channel_count(channels) > 1:
        moved_from(ids_before, ids_now, centres_before, centres_now, moved)
    sense(0, pose, physics, beams, channels, walls, cell_start, cell_walls, all_walls, True,
          corners_now, visible, moved, -1, state.work.readings, state.work.seen)
    return RUNNING


@njit(cache=True, inline="always")
def learner_move(physics, state) -> None:
    """Step 4 of :func:`learner_step`: the learner moves by ``state.work.steering``."""
    move_all(state.work.steering, physics, state.learner)


@njit(cache=True, inline="always")
def learner_step(t, genes, layer_sizes, physics, geometry, ids, corners, centres, before, now,
                 max_steps, state):
    """One step of the learner among the traffic of rows ``before`` (the step before) and
    ``now`` of the slot arrays ``ids``, ``corners`` and ``centres``: the fringe, collisions,
    spin test and step cap, then sense (:func:`learner_sense`), decide and move. Returns an
    outcome code, or ``RUNNING``; updates ``state`` (a :class:`LearnerState`) in place."""
    outcome = learner_sense(t, physics, geometry, ids, corners, centres, before, now, max_steps,
                            state)
    if outcome != RUNNING:
        return outcome
    work = state.work
    work.steering[0] = network_steering(genes, layer_sizes, work.readings, work.activation,
                                        work.scratch, physics.gain)
    learner_move(physics, state)
    return RUNNING


# The two halves alone, for a caller that steers from outside (enn_traffic.envs.sumo).
sense_once = njit(cache=True)(learner_sense.py_func)
move_once = njit(cache=True)(learner_move.py_func)


def compiled_step(*args):
    """:func:`learner_step` compiled for the types of ``args``, for a loop in Python that
    calls it on every step (the closed loop). Through numba's dispatcher a call took 21 µs,
    compiled 16 µs: the dispatcher types a NamedTuple of more than 10 fields (``Physics``,
    :class:`LearnerState`) on its slow path (numba issue 6144)."""
    return learner_step.compile(tuple(numba.typeof(value) for value in args))


@njit(cache=True)
def run_replay_life(genes, layer_sizes, physics, geometry, start, ids, corners, centres,
                    max_steps, trace, end):
    """Drive one chromosome through a recorded traffic run (``ids`` etc. hold at least
    ``max_steps + 1`` steps). Returns (steps moved, outcome, collisions suffered, vehicle-steps
    within sensor range, most at once, what it hit: ``NO_HIT``, ``HIT_WALL`` or the vehicle's
    id); ``trace`` (n, 3) receives the learner's poses of steps 0..n-1 when n > 0, ``end``
    (3,) its pose as the life ended (where it collided, left or was capped)."""
    state = learner_state(start, physics, geometry, layer_sizes,
                          ids.shape[1])
    pose, suffered, met = state.learner.pose, state.suffered, state.met
    clear_start(state.learner.centres, ids[0], centres[0], state.gone, physics.clearance)
    t = 0
    while True:
        if t < trace.shape[0]:
            copy_row(pose[0], trace[t])
        outcome = learner_step(t, genes, layer_sizes, physics, geometry, ids, corners, centres,
                               max(t - 1, 0), t, max_steps, state)
        if outcome != RUNNING:
            copy_row(pose[0], end)
            return t, outcome, suffered[0], met[0], met[1], state.hit[0]
        t += 1


@njit(cache=True, parallel=True)
def run_replay_population(population, layer_sizes, physics, geometry, start, ids, corners,
                          centres, max_steps):
    """:func:`run_replay_life` for every chromosome of ``population`` (P, G), spread over
    the cores; per world (steps, outcome, collisions suffered, vehicle-steps within sensor
    range, most at once, what the learner hit) and the learner's pose as its life ended
    (P, 3)."""
    size = population.shape[0]
    steps, outcome, suffered, near_steps, near_max, hit = life_columns(size)
    end = np.empty((size, 3))
    no_trace = np.empty((0, 3))
    for p in prange(size):
        (steps[p], outcome[p], suffered[p], near_steps[p], near_max[p],
         hit[p]) = run_replay_life(population[p], layer_sizes, physics, geometry, start, ids,
                                   corners, centres, max_steps, no_trace, end[p])
    return steps, outcome, suffered, near_steps, near_max, hit, end
