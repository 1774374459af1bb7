"""The learner among traffic it does not steer, given as bodies step by step (docs/sumo.md).

The traffic comes from SUMO: recorded once per traffic seed and replayed to every world of a
generation (replay mode), or read from a live SUMO after each step (closed-loop mode, where
SUMO also sees the learner). Both modes run the same compiled step, :func:`learner_step`, so
they agree wherever the traffic does not react to the learner.

Traffic at step ``t`` is a set of slots: ``ids[t]`` (S,) the vehicle in each slot (-1: empty),
``corners[t]`` (S, 4, 2) its body and ``centres[t]`` (S, 2) the body's centre. The blame rule
is the arena's (:mod:`enn_traffic.sim.world`, paper §5.3): the learner is responsible if its
body touches a wall or a vehicle's body from before the step; a vehicle whose body touches the
learner's body from before the step is responsible, counts as a collision the learner suffered,
and leaves this world (``gone``), as an arena vehicle respawns. Vehicles within
``respawn_clearance`` of the learner's start leave the world before the first step. A learner
whose body touches an exit (the network's fringe, docs/sumo.md) has left the network.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from enn_traffic.sim.collide import (
    body_corners,
    box_hits_segment,
    box_hits_walls,
    boxes_overlap,
)
from enn_traffic.sim.kinematics import bicycle_step
from enn_traffic.sim.sensors import nearby_walls, sense_walls
from enn_traffic.sim.world import (
    CAPPED,
    COLLIDED,
    LEFT_NETWORK,
    SPUN,
    _sense_bodies,
    _small_spread,
    network_steering,
    within_range,
)

RUNNING = -1
FAR = 1e12  # where an absent vehicle's centre is put, out of every range

# Layout of the float vector ``physics``.
LENGTH, WIDTH, WHEELBASE, DISTANCE, MAX_RANGE, GAIN, RADIUS, SPIN_VARIANCE, CLEARANCE = range(9)


def physics_vector(length, width, wheelbase, distance, max_range, gain, radius, spin_variance,
                   clearance) -> np.ndarray:
    """The learner's constants in the order :func:`learner_step` reads them."""
    return np.array([length, width, wheelbase, distance, max_range, gain, radius, spin_variance,
                     clearance], dtype=np.float64)


@njit(cache=True)
def _visible(ids, gone, s) -> bool:
    return ids[s] >= 0 and ids[s] != gone[s]


@njit(cache=True)
def clear_start(body, ids, centres, gone, clearance) -> None:
    """Take vehicles within ``clearance`` of the learner's body centre out of the world."""
    cx = 0.5 * (body[0, 0] + body[2, 0])
    cy = 0.5 * (body[0, 1] + body[2, 1])
    for s in range(ids.shape[0]):
        if ids[s] >= 0 and math.hypot(centres[s, 0] - cx, centres[s, 1] - cy) < clearance:
            gone[s] = ids[s]


@njit(cache=True)
def learner_step(
    t, genes, layer_sizes, physics, beam_cos, beam_sin, walls, lookup, exits,
    ids_before, corners_before, centres_before, ids_now, corners_now, centres_now,
    max_steps, spin_window, pose, body, body_before, recent, gone, suffered, met, readings,
    activation, scratch, visible_centres,
):  # fmt: skip
    """One step of the learner at pose ``pose`` (its body ``body``, ``body_before`` the step
    before): the fringe, collisions, spin test and step cap, then sense, decide and move.
    Returns an outcome code, or ``RUNNING``; updates ``pose``, ``body``, ``body_before``,
    ``recent``, ``gone``, ``suffered[0]`` and the traffic met (``met``: vehicle-steps within
    sensor range, most at once) in place."""
    radius = physics[RADIUS]
    near = 4.0 * radius * radius
    cx = 0.5 * (body[0, 0] + body[2, 0])
    cy = 0.5 * (body[0, 1] + body[2, 1])
    # 0. the fringe: an exit reached ends the life, whatever else the body touches
    for e in range(exits.shape[0]):
        if box_hits_segment(body, exits[e, 0], exits[e, 1], exits[e, 2], exits[e, 3]):
            return LEFT_NETWORK
    # 1. collisions by the blame rule
    candidates = nearby_walls(pose[0], pose[1], lookup)
    if box_hits_walls(body, walls, candidates, candidates.shape[0]):
        return COLLIDED
    if t > 0:
        for s in range(ids_before.shape[0]):
            if not _visible(ids_before, gone, s):
                continue
            dx, dy = centres_before[s, 0] - cx, centres_before[s, 1] - cy
            if dx * dx + dy * dy <= near and boxes_overlap(body, corners_before[s]):
                return COLLIDED
        bx = 0.5 * (body_before[0, 0] + body_before[2, 0])
        by = 0.5 * (body_before[0, 1] + body_before[2, 1])
        for s in range(ids_now.shape[0]):
            if not _visible(ids_now, gone, s):
                continue
            dx, dy = centres_now[s, 0] - bx, centres_now[s, 1] - by
            if dx * dx + dy * dy <= near and boxes_overlap(corners_now[s], body_before):
                gone[s] = ids_now[s]
                suffered[0] += 1
    # 2. spin test and step cap
    slot = t % spin_window
    recent[slot, 0], recent[slot, 1] = pose[0], pose[1]
    if t + 1 >= spin_window and _small_spread(recent, physics[SPIN_VARIANCE]):
        return SPUN
    if t >= max_steps:
        return CAPPED
    # 3. sense walls and the visible vehicles, decide
    sense_walls(pose[0], pose[1], pose[2], beam_cos, beam_sin, physics[MAX_RANGE], walls,
                candidates, readings)
    for s in range(ids_now.shape[0]):
        if _visible(ids_now, gone, s):
            visible_centres[s, 0], visible_centres[s, 1] = centres_now[s, 0], centres_now[s, 1]
        else:
            visible_centres[s, 0], visible_centres[s, 1] = FAR, FAR
    within = within_range(pose[0], pose[1], visible_centres, 0, physics[MAX_RANGE] + radius)
    met[0] += within
    met[1] = max(met[1], within)
    _sense_bodies(-1, pose[0], pose[1], pose[2], beam_cos, beam_sin, corners_now,
                  visible_centres, radius, readings)
    steering = network_steering(genes, layer_sizes, readings, activation, scratch,
                                physics[GAIN])
    # 4. move
    body_before[:] = body
    pose[0], pose[1], pose[2] = bicycle_step(pose[0], pose[1], pose[2], steering,
                                             physics[DISTANCE], physics[WHEELBASE])
    body_corners(pose[0], pose[1], pose[2], physics[LENGTH], physics[WIDTH], body)
    return RUNNING


@njit(cache=True)
def learner_state(start, physics, layer_sizes, beams, slots, spin_window):
    """Fresh per-episode arrays for :func:`learner_step`: pose, body, body before, recent
    positions, gone, suffered, traffic met, readings, activation, scratch, visible centres."""
    pose = start.copy()
    body = np.empty((4, 2))
    body_corners(pose[0], pose[1], pose[2], physics[LENGTH], physics[WIDTH], body)
    width_max = max(layer_sizes.max(), 2)
    return (pose, body, body.copy(), np.empty((spin_window, 2)), np.full(slots, -1, np.int64),
            np.zeros(1, np.int64), np.zeros(2, np.int64), np.empty(beams), np.empty(width_max),
            np.empty(width_max), np.empty((slots, 2)))


@njit(cache=True)
def run_replay_episode(genes, layer_sizes, physics, start, beam_cos, beam_sin, walls, lookup,
                       exits, ids, corners, centres, max_steps, spin_window, trace):
    """Drive one chromosome through a recorded traffic run (``ids`` etc. hold at least
    ``max_steps + 1`` steps). Returns (steps moved, outcome, collisions suffered, vehicle-steps
    within sensor range, most at once); ``trace`` (n, 3) receives the learner's poses of steps
    0..n-1 when n > 0."""
    state = learner_state(start, physics, layer_sizes, beam_cos.shape[0], ids.shape[1],
                          spin_window)
    pose, body, body_before, recent, gone, suffered, met = state[:7]
    readings, activation, scratch, visible = state[7:]
    clear_start(body, ids[0], centres[0], gone, physics[CLEARANCE])
    t = 0
    while True:
        if t < trace.shape[0]:
            trace[t] = pose
        before = max(t - 1, 0)
        outcome = learner_step(
            t, genes, layer_sizes, physics, beam_cos, beam_sin, walls, lookup, exits,
            ids[before], corners[before], centres[before], ids[t], corners[t], centres[t],
            max_steps, spin_window, pose, body, body_before, recent, gone, suffered, met,
            readings, activation, scratch, visible,
        )  # fmt: skip
        if outcome != RUNNING:
            return t, outcome, suffered[0], met[0], met[1]
        t += 1


@njit(cache=True, parallel=True)
def run_replay_population(population, layer_sizes, physics, start, beam_cos, beam_sin, walls,
                          lookup, exits, ids, corners, centres, max_steps, spin_window):
    """:func:`run_replay_episode` for every chromosome of ``population`` (P, G), spread over
    the cores; per world (steps, outcome, collisions suffered, vehicle-steps within sensor
    range, most at once)."""
    size = population.shape[0]
    steps = np.zeros(size, dtype=np.int64)
    outcome = np.zeros(size, dtype=np.int64)
    suffered = np.zeros(size, dtype=np.int64)
    near_steps = np.zeros(size, dtype=np.int64)
    near_max = np.zeros(size, dtype=np.int64)
    no_trace = np.empty((0, 3))
    for p in prange(size):
        steps[p], outcome[p], suffered[p], near_steps[p], near_max[p] = run_replay_episode(
            population[p], layer_sizes, physics, start, beam_cos, beam_sin, walls, lookup,
            exits, ids, corners, centres, max_steps, spin_window, no_trace)
    return steps, outcome, suffered, near_steps, near_max
