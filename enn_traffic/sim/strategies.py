"""Movement strategies of the uncontrolled vehicles in the arena (paper §5.3, Figure 11).

Every uncontrolled vehicle uses the learner's bicycle model and rangefinder. Its steering comes
from its strategy:

1. ``random_network`` — a fixed random network (genes U[-1, 1]) on its own readings: the
   paper's setup, where every vehicle starts with random weights and a random heading.
2. ``straight`` — drives straight; when a wall is closer than ``turn_distance`` within
   ±``turn_cone_deg`` ahead, it turns towards the more open side until that cone is clear
   (``turn_distance = 0``: it never turns, and respawns at the wall); ``turn_side = "left"``
   or ``"right"`` always turns that way, a one-way flow round the walls.
3. ``circling`` — every vehicle drives circles of its own: a radius drawn from
   ``circle_radius`` and a direction (left or right) drawn each life, so it holds the steering
   angle of that circle; near a wall it turns away as ``straight`` does, then circles on about
   a new centre. Circles of different radii, anywhere in the area, crossing each other.
4. ``wander`` — steering follows a random process, δ ← decay·δ + Normal(0, σ); near a wall it
   turns away as ``straight`` does.

Scripted vehicles see walls only, unless ``sees_vehicles``: then other vehicles' bodies in the
cone ahead start a turn as a wall does.

An uncontrolled vehicle responsible for a collision respawns at a free spot. All randomness
comes from one counter-based generator per world (:func:`next_uniform`), seeded the same for
every world, so each chromosome meets the same traffic.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from enn_traffic.config.traffic import CIRCLING, NETWORK, NONE, STRAIGHT, WANDER
from enn_traffic.sim.readings import COS, RANGE, SIN

TURN_SIDES = {"open": 0.0, "left": 1.0, "right": -1.0}


# The scripted strategies' settings (``[traffic]``, :func:`strategy_settings`) travel in the
# world's constants (:data:`enn_traffic.sim.rules.Physics`), the ``params`` of the kernels
# below, as these fields; the kernels also read its ``wheelbase``.
STRATEGY_FIELDS = {"turn_distance": float, "turn_steering": float, "turn_cone": float,
                   "circle_radius_min": float, "circle_radius_max": float,
                   "wander_sigma": float, "wander_decay": float, "wander_max": float,
                   "turn_side": float, "sees_vehicles": bool}


def strategy_settings(traffic) -> dict[str, float | bool]:
    """The :data:`STRATEGY_FIELDS` of a scenario's ``[traffic]`` section, in radians and
    metres (``turn_side``: 1 left, -1 right, 0 the more open side)."""
    low, high = traffic.circle_radius
    return {"turn_distance": traffic.turn_distance,
            "turn_steering": math.radians(traffic.turn_steering_deg),
            "turn_cone": math.radians(traffic.turn_cone_deg),
            "circle_radius_min": float(low), "circle_radius_max": float(high),
            "wander_sigma": math.radians(traffic.wander_sigma_deg),
            "wander_decay": traffic.wander_decay,
            "wander_max": math.radians(traffic.wander_max_deg),
            "turn_side": TURN_SIDES[traffic.turn_side],
            "sees_vehicles": bool(traffic.sees_vehicles)}


_GOLDEN = np.uint64(0x9E3779B97F4A7C15)
_MIX1 = np.uint64(0xBF58476D1CE4E5B9)
_MIX2 = np.uint64(0x94D049BB133111EB)


@njit(cache=True)
def next_uniform(state) -> float:
    """A U[0, 1) draw from the splitmix64 generator whose state is ``state[0]`` (uint64)."""
    state[0] += _GOLDEN
    z = state[0]
    z = (z ^ (z >> np.uint64(30))) * _MIX1
    z = (z ^ (z >> np.uint64(27))) * _MIX2
    z = z ^ (z >> np.uint64(31))
    return float(z >> np.uint64(11)) * (1.0 / 9007199254740992.0)


@njit(cache=True)
def next_normal(state) -> float:
    """A standard normal draw (Box–Muller)."""
    u1 = max(next_uniform(state), 1e-300)
    u2 = next_uniform(state)
    return math.sqrt(-2.0 * math.log(u1)) * math.cos(2.0 * math.pi * u2)


@njit(cache=True)
def reset_memory(kind, params, rng, memory) -> None:
    """A vehicle's per-life strategy state: ``memory[0]`` is its circle's steering angle
    (circling) or its wander steering, ``memory[1]`` its current turn away from a wall (0: none)."""
    memory[0] = 0.0
    memory[1] = 0.0
    if kind == CIRCLING:
        low, high = params.circle_radius_min, params.circle_radius_max
        radius = low + (high - low) * next_uniform(rng)
        side = 1.0 if next_uniform(rng) < 0.5 else -1.0
        memory[0] = side * circle_steering(radius, params.wheelbase)


@njit(cache=True, inline="always")
def senses_vehicles(kind, params) -> bool:
    """Does an uncontrolled vehicle of ``kind`` sense other vehicles' bodies? A network
    always does; a scripted driver only with ``sees_vehicles``."""
    return kind == NETWORK or (kind != NONE and params.sees_vehicles)


@njit(cache=True)
def circle_steering(radius, wheelbase) -> float:
    """The steering angle that keeps the bicycle model of :mod:`enn_traffic.sim.bicycle` on
    a circle of ``radius``: its front and rear points move apart by the angle δ, so the pose
    turns on a circle of wheelbase / (2 sin(δ/2))."""
    return 2.0 * math.asin(min(0.5 * wheelbase / radius, 1.0))


@njit(cache=True)
def scripted_steering(kind, readings, beams, params, memory, rng) -> float:
    """Steering of a scripted (non-network) strategy: a turn away from a wall when there is
    one, else the strategy's own steering ``memory[0]`` (0 when driving straight, the circle's,
    or the wander process's, updated here)."""
    if kind == WANDER:
        limit = params.wander_max
        value = params.wander_decay * memory[0] + params.wander_sigma * next_normal(rng)
        memory[0] = min(max(value, -limit), limit)
    if kind in (STRAIGHT, CIRCLING, WANDER):
        turn = wall_turn(readings, beams, params, memory)
        return turn if turn != 0.0 else memory[0]
    return 0.0


@njit(cache=True)
def wall_turn(readings, beams, params, memory) -> float:
    """Turn away from what is ahead: start when something is nearer than ``turn_distance`` in
    the cone ahead, keep turning the same way until nothing at all is in range there (a vehicle
    that meets a wall head-on turns about 90° and drives on along it). The way is the more open
    side, or always left or right (``turn_side``: 1 left, -1 right, 0 open). 0: no turn."""
    cone = math.cos(params.turn_cone)
    nearest = np.inf
    clear = True  # every beam in the cone reads its full range
    left, right = 0.0, 0.0
    for b in range(readings.shape[0]):
        if beams[b, COS] >= cone:
            nearest = min(nearest, readings[b])
            clear = clear and readings[b] >= beams[b, RANGE]
        if beams[b, SIN] > 0.0:
            left += readings[b]
        elif beams[b, SIN] < 0.0:
            right += readings[b]
    if memory[1] == 0.0 and nearest < params.turn_distance:
        side = params.turn_side
        if side == 0.0:
            side = 1.0 if left >= right else -1.0
        memory[1] = side * params.turn_steering
    elif memory[1] != 0.0 and clear:
        memory[1] = 0.0
    return memory[1]
