"""Batched worlds and the episode loop (paper §4–§5.4).

A world holds one learning vehicle (index 0), driven by the chromosome under evaluation, and
``V - 1`` uncontrolled vehicles driven by a traffic strategy (:mod:`enn_traffic.traffic.kinematic`).
Every evaluation resets the whole world to the same start (§5.3). Each step:

1. collisions at the current poses, by the blame rule (docs/design.md): a vehicle is responsible if
   its body touches a wall or the body another vehicle had *before* the step. The learner's
   life ends at its first responsible collision; an uncontrolled vehicle that is responsible
   respawns at a free spot, and if it ran into the learner the learner's ``suffered`` count
   rises (a collision the learner did not cause);
2. the spin test (the learner's positions over the last ``spin_window`` poses have variance at
   most ``spin_variance`` on both axes: fitness 0) and the step cap;
3. every vehicle senses (walls and every other vehicle's body) and decides its steering;
4. every vehicle moves (bicycle model).

All P worlds of a generation run in one compiled call spread over the cores with ``prange``;
each world stops at its own end, and the call returns when all have.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import numba
import numpy as np
from numba import njit, prange

from enn_traffic.errors import InputError
from enn_traffic.evolution.genome import NetworkSpec
from enn_traffic.roads import Track, load_track
from enn_traffic.roads.network import start_poses as start_lane_poses
from enn_traffic.scenario import Scenario
from enn_traffic.sim.collide import body_corners, box_hits_walls, boxes_overlap
from enn_traffic.sim.kinematics import bicycle_step
from enn_traffic.sim.sensors import WallGrid, nearby_walls, ray_segment_distance, sense_walls
from enn_traffic.traffic import kinematic
from enn_traffic.traffic.kinematic import (
    NONE,
    P_CLEARANCE,
    RANDOM_NETWORK,
    next_uniform,
    reset_memory,
    scripted_steering,
    senses_vehicles,
)

# How an episode ended. LEFT_NETWORK: the learner reached the network's fringe (SUMO traffic,
# docs/sumo.md "Walls and exits"): its steps count as fitness, as a capped life's do.
CAPPED, COLLIDED, SPUN, LEFT_NETWORK = 0, 1, 2, 3
OUTCOMES = {CAPPED: "capped", COLLIDED: "collision", SPUN: "spin", LEFT_NETWORK: "left network"}
# Columns of :attr:`EpisodeResults.traffic`: vehicles in the world when the learner starts,
# vehicle-steps within the learner's sensor range, most vehicles within range at once.
MET_START, MET_NEAR_STEPS, MET_NEAR_MAX = range(3)
# Columns of :attr:`EpisodeResults.safety` (closed loop with SUMO only): the lowest
# time-to-collision its SSM device saw (s; inf: none), conflicts by TTC, DRAC and PET.
SAFETY_MIN_TTC, SAFETY_TTC, SAFETY_DRAC, SAFETY_PET = range(4)
# What the blame rule found (:func:`_responsible`), besides the index of a vehicle.
NO_HIT, HIT_WALL = -1, -2
# Generation keys from here on draw held-out traffic (deployment, validation, the tables'
# situations): far past any training run, and never folded into the training traffic by
# ``vary = "fixed"``.
HELD_OUT_KEYS = 1_000_000_000
START_STREAM = 5  # the last key of the seed that draws a situation's start from a list


@njit(cache=True)
def network_steering(genes, layer_sizes, readings, activation, scratch, gain):
    """Steering angle = gain · (left − right) from a source-layout chromosome (paper §3)."""
    for i in range(layer_sizes[0]):
        activation[i] = readings[i]
    offset = 0
    for layer in range(layer_sizes.shape[0] - 1):
        n_in, n_out = layer_sizes[layer], layer_sizes[layer + 1]
        bias = offset + n_in * n_out
        for j in range(n_out):
            scratch[j] = genes[bias + j]
        for i in range(n_in):
            a = activation[i]
            base = offset + i * n_out
            for j in range(n_out):
                scratch[j] += a * genes[base + j]
        for j in range(n_out):
            activation[j] = 1.0 / (1.0 + math.exp(-scratch[j]))
        offset = bias + n_out
    return gain * (activation[1] - activation[0])


@njit(cache=True)
def _sense_bodies(v, x, y, heading, beam_cos, beam_sin, corners, centres, radius, readings):
    """Lower ``readings`` of vehicle ``v`` to the nearest edge of any other vehicle's body."""
    cos_h, sin_h = math.cos(heading), math.sin(heading)
    for other in range(corners.shape[0]):
        if other == v:
            continue
        dx, dy = centres[other, 0] - x, centres[other, 1] - y
        if math.hypot(dx, dy) - radius > readings.max():
            continue
        for b in range(beam_cos.shape[0]):
            ux = cos_h * beam_cos[b] - sin_h * beam_sin[b]
            uy = sin_h * beam_cos[b] + cos_h * beam_sin[b]
            along = dx * ux + dy * uy
            if along < -radius or along - radius > readings[b] or abs(dx * uy - dy * ux) > radius:
                continue  # the beam passes clear of the body's bounding circle
            for i in range(4):
                j = (i + 1) % 4
                d = ray_segment_distance(
                    x, y, ux, uy, readings[b], corners[other, i, 0], corners[other, i, 1],
                    corners[other, j, 0], corners[other, j, 1],
                )  # fmt: skip
                if d < readings[b]:
                    readings[b] = d


@njit(cache=True)
def _inside(x, y, walls) -> bool:
    """Is (x, y) inside the area the closed wall rings bound? (crossing number)"""
    inside = False
    for w in range(walls.shape[0]):
        x1, y1, x2, y2 = walls[w, 0], walls[w, 1], walls[w, 2], walls[w, 3]
        if (y1 > y) != (y2 > y) and x < x1 + (y - y1) * (x2 - x1) / (y2 - y1):
            inside = not inside
    return inside


@njit(cache=True)
def _place(v, x, y, heading, length, width, pose, corners, centres):
    """Put vehicle ``v`` at (x, y, heading): its pose, body corners and body centre."""
    pose[v, 0], pose[v, 1], pose[v, 2] = x, y, heading
    body_corners(x, y, heading, length, width, corners[v])
    centres[v, 0] = 0.5 * (corners[v, 0, 0] + corners[v, 2, 0])
    centres[v, 1] = 0.5 * (corners[v, 0, 1] + corners[v, 2, 1])


@njit(cache=True)
def _respawn(v, pose, corners, centres, length, width, walls, lookup, bounds, clearance, rng):
    """Move vehicle ``v`` to a random free pose: on the drivable area, touching no wall, and at
    least ``clearance`` from every other vehicle. Returns False if none was found."""
    trial = np.empty((4, 2))
    for _ in range(200):
        x = bounds[0] + (bounds[2] - bounds[0]) * next_uniform(rng)
        y = bounds[1] + (bounds[3] - bounds[1]) * next_uniform(rng)
        heading = math.pi * (2.0 * next_uniform(rng) - 1.0)
        if not _inside(x, y, walls):
            continue
        body_corners(x, y, heading, length, width, trial)
        candidates = nearby_walls(x, y, lookup)
        if box_hits_walls(trial, walls, candidates, candidates.shape[0]):
            continue
        if not _inside(trial[2, 0], trial[2, 1], walls):
            continue
        free = True
        for other in range(pose.shape[0]):
            if other != v and math.hypot(x - pose[other, 0], y - pose[other, 1]) < clearance:
                free = False
                break
        if free:
            _place(v, x, y, heading, length, width, pose, corners, centres)
            return True
    return False


@njit(cache=True)
def run_episode(
    genes, layer_sizes, gain, start, kinds, traffic_genes,
    length, width, wheelbase, distance, beam_cos, beam_sin, max_range,
    walls, lookup, bounds, params, seed,
    max_steps, spin_window, spin_variance, trace,
):  # fmt: skip
    """Drive one chromosome as vehicle 0 among ``start.shape[0] - 1`` uncontrolled vehicles.

    Returns (steps moved, outcome, collisions suffered, vehicle-steps within the learner's
    sensor range, most vehicles within it at once). ``trace`` (n, V, 3) receives the poses of
    steps 0..n-1 when n > 0.
    """
    count = start.shape[0]
    pose = np.empty((count, 3))
    corners = np.empty((count, 4, 2))
    previous = np.empty((count, 4, 2))
    centres = np.empty((count, 2))
    previous_centres = np.empty((count, 2))
    fresh = np.zeros(count, dtype=np.bool_)  # respawned: no earlier body to blame against
    memory = np.zeros((count, 2))
    steering = np.zeros(count)
    rng = np.full(1, seed, dtype=np.uint64)
    radius = 0.5 * math.hypot(length, width)
    readings = np.empty(beam_cos.shape[0])
    width_max = max(layer_sizes.max(), 2)
    activation = np.empty(width_max)
    scratch = np.empty(width_max)
    recent = np.empty((spin_window, 2))
    for v in range(count):
        reset_memory(kinds[v], params, rng, memory[v])
        _place(v, start[v, 0], start[v, 1], start[v, 2], length, width, pose, corners, centres)
    previous[:] = corners
    previous_centres[:] = centres
    near = 4.0 * radius * radius  # bodies whose centres are farther apart cannot touch
    suffered = 0
    near_steps, near_max = 0, 0
    steps = 0
    while True:
        if steps < trace.shape[0]:
            trace[steps] = pose
        # 1. collisions by the blame rule
        if _responsible(0, pose, corners, centres, previous, previous_centres, fresh, walls,
                        lookup, near) != NO_HIT:
            return steps, COLLIDED, suffered, near_steps, near_max
        for v in range(1, count):
            hit = _responsible(v, pose, corners, centres, previous, previous_centres, fresh,
                               walls, lookup, near)
            if hit == 0:
                suffered += 1
            if hit != NO_HIT and _respawn(v, pose, corners, centres, length, width, walls, lookup,
                                bounds, params[P_CLEARANCE], rng):
                previous[v] = corners[v]
                previous_centres[v] = centres[v]
                fresh[v] = True
                reset_memory(kinds[v], params, rng, memory[v])
        # 2. spin test and step cap for the learner
        slot = steps % spin_window
        recent[slot, 0], recent[slot, 1] = pose[0, 0], pose[0, 1]
        if steps + 1 >= spin_window and _small_spread(recent, spin_variance):
            return steps, SPUN, suffered, near_steps, near_max
        if steps >= max_steps:
            return steps, CAPPED, suffered, near_steps, near_max
        within = within_range(pose[0, 0], pose[0, 1], centres, 1, max_range + radius)
        near_steps += within
        near_max = max(near_max, within)
        # 3. sense and decide
        for v in range(count):
            kind = kinds[v]
            if v == 0 or kind != NONE:
                candidates = nearby_walls(pose[v, 0], pose[v, 1], lookup)
                sense_walls(pose[v, 0], pose[v, 1], pose[v, 2], beam_cos, beam_sin, max_range,
                            walls, candidates, readings)
                if count > 1 and (v == 0 or senses_vehicles(kind, params)):
                    _sense_bodies(v, pose[v, 0], pose[v, 1], pose[v, 2], beam_cos, beam_sin,
                                  corners, centres, radius, readings)
            if v == 0:
                steering[v] = network_steering(genes, layer_sizes, readings, activation,
                                               scratch, gain)
            elif kind == RANDOM_NETWORK:
                steering[v] = network_steering(traffic_genes[v], layer_sizes, readings,
                                               activation, scratch, gain)
            elif kind != NONE:
                steering[v] = scripted_steering(kind, readings, beam_cos, beam_sin, max_range,
                                                params, memory[v], rng)
        # 4. move
        previous[:] = corners
        previous_centres[:] = centres
        fresh[:] = False
        for v in range(count):
            x, y, heading = bicycle_step(pose[v, 0], pose[v, 1], pose[v, 2], steering[v],
                                         distance, wheelbase)
            _place(v, x, y, heading, length, width, pose, corners, centres)
        steps += 1


@njit(cache=True)
def _responsible(v, pose, corners, centres, previous, previous_centres, fresh, walls, lookup,
                 near) -> int:
    """The blame rule (docs/design.md) for vehicle ``v``: ``HIT_WALL`` if its body touches a wall,
    else the first other vehicle whose body from before the step it touches (a vehicle that
    just respawned has no such body), else ``NO_HIT``. ``near``: the squared distance of body
    centres beyond which bodies cannot touch."""
    candidates = nearby_walls(pose[v, 0], pose[v, 1], lookup)
    if box_hits_walls(corners[v], walls, candidates, candidates.shape[0]):
        return HIT_WALL
    for other in range(corners.shape[0]):
        if (other != v and not fresh[other] and _close(centres, v, previous_centres, other, near)
                and boxes_overlap(corners[v], previous[other])):
            return other
    return NO_HIT


@njit(cache=True)
def within_range(x, y, centres, first, reach) -> int:
    """How many of ``centres[first:]`` lie within ``reach`` of (x, y) (traffic met)."""
    count = 0
    for v in range(first, centres.shape[0]):
        if (centres[v, 0] - x) ** 2 + (centres[v, 1] - y) ** 2 <= reach * reach:
            count += 1
    return count


@njit(cache=True)
def _close(centres, a, other_centres, b, limit) -> bool:
    """Are the centres of body ``a`` and (earlier) body ``b`` within sqrt(limit)?"""
    dx = centres[a, 0] - other_centres[b, 0]
    dy = centres[a, 1] - other_centres[b, 1]
    return dx * dx + dy * dy <= limit


@njit(cache=True)
def _small_spread(points, limit) -> bool:
    """Population variance of x and of y both at most ``limit``."""
    n = points.shape[0]
    mx = points[:, 0].sum() / n
    my = points[:, 1].sum() / n
    vx = ((points[:, 0] - mx) ** 2).sum() / n
    vy = ((points[:, 1] - my) ** 2).sum() / n
    return vx <= limit and vy <= limit


@njit(cache=True, parallel=True)
def run_population(
    population, layer_sizes, gain, start, kinds, traffic_genes,
    length, width, wheelbase, distance, beam_cos, beam_sin, max_range,
    walls, lookup, bounds, params, seed,
    max_steps, spin_window, spin_variance,
):  # fmt: skip
    """Run every chromosome of ``population`` (P, G) in its own world; per world
    (steps, outcome, collisions suffered, vehicle-steps within sensor range, most at once)."""
    size = population.shape[0]
    steps = np.zeros(size, dtype=np.int64)
    outcome = np.zeros(size, dtype=np.int64)
    suffered = np.zeros(size, dtype=np.int64)
    near_steps = np.zeros(size, dtype=np.int64)
    near_max = np.zeros(size, dtype=np.int64)
    no_trace = np.empty((0, start.shape[0], 3))
    for p in prange(size):
        steps[p], outcome[p], suffered[p], near_steps[p], near_max[p] = run_episode(
            population[p], layer_sizes, gain, start, kinds, traffic_genes,
            length, width, wheelbase, distance, beam_cos, beam_sin, max_range,
            walls, lookup, bounds, params, seed,
            max_steps, spin_window, spin_variance, no_trace,
        )  # fmt: skip
    return steps, outcome, suffered, near_steps, near_max


@dataclass(frozen=True)
class EpisodeResults:
    """Per world and episode (P, E): learner steps, outcome (``OUTCOMES``), collisions the
    learner suffered, and the traffic it met (P, E, 3; columns ``MET_*``); fitness (P,) is
    the mean over episodes of steps, 0 for a spin."""

    fitness: np.ndarray
    steps: np.ndarray
    outcome: np.ndarray
    suffered: np.ndarray
    vehicles: int = 1
    traffic: np.ndarray | None = None
    safety: np.ndarray | None = None  # (P, E, 4), ``SAFETY_*``: measured in closed loop only

    def __post_init__(self):
        if self.traffic is None:  # no traffic: nothing met
            object.__setattr__(self, "traffic", np.zeros((*self.steps.shape, 3)))

    @staticmethod
    def traffic_met(start: np.ndarray, near_steps: np.ndarray, near_max: np.ndarray
                    ) -> np.ndarray:
        """The ``traffic`` array from its three (P, E) columns."""
        return np.stack(np.broadcast_arrays(start, near_steps, near_max), axis=-1
                        ).astype(np.float64)

    def traffic_summary(self) -> dict[str, float]:
        """Traffic the learners met, over all worlds and episodes: vehicles in the world at
        the start (mean), vehicles within sensor range per learner step (mean; the steps of
        the life and the start) and at most."""
        t = self.traffic
        return {
            "traffic_at_start": float(t[..., MET_START].mean()) if t.size else 0.0,
            "traffic_near_mean": float(t[..., MET_NEAR_STEPS].sum() / (self.steps + 1).sum())
            if t.size else 0.0,
            "traffic_near_max": float(t[..., MET_NEAR_MAX].max()) if t.size else 0.0,
        }

    @staticmethod
    def lifetime_fitness(steps: np.ndarray, outcome: np.ndarray) -> np.ndarray:
        """Fitness of each episode (paper §5, §5.3): steps survived, 0 for a spin."""
        return np.where(outcome == SPUN, 0, steps).astype(np.float64)

    @property
    def vehicle_steps(self) -> int:
        """Steps moved by every simulated vehicle."""
        return int(self.steps.sum()) * self.vehicles

    @staticmethod
    def concatenate(parts: list[EpisodeResults]) -> EpisodeResults:
        return EpisodeResults(*(np.concatenate([getattr(p, f) for p in parts])
                                for f in ("fitness", "steps", "outcome", "suffered")),
                              vehicles=parts[0].vehicles,
                              traffic=np.concatenate([p.traffic for p in parts]),
                              safety=None if any(p.safety is None for p in parts)
                              else np.concatenate([p.safety for p in parts]))


@dataclass(frozen=True)
class Episode:
    """One traffic situation: every vehicle's start pose, strategy and (for random networks)
    genes, and the seed of the world's generator."""

    start: np.ndarray  # (V, 3)
    kinds: np.ndarray  # (V,)
    traffic_genes: np.ndarray  # (V, G), source layout
    seed: np.uint64


class Physics(NamedTuple):
    """The constants every world kernel takes, in their argument order."""

    length: float
    width: float
    wheelbase: float
    distance: float  # metres per step
    beam_cos: np.ndarray
    beam_sin: np.ndarray
    max_range: float
    walls: np.ndarray
    lookup: tuple
    bounds: np.ndarray
    params: np.ndarray  # traffic strategy parameters (traffic/kinematic.py)


class World:
    """A scenario's worlds: its track, learner and traffic, ready to evaluate populations."""

    def __init__(self, scenario: Scenario, track: Track | None = None):
        self.scenario = scenario
        self.track = track or load_track(scenario.track.net, exits=scenario.fringe_exits)
        self.exits = self.track.exits if scenario.fringe_exits else np.empty((0, 4))
        self.spec = NetworkSpec(scenario.layer_sizes, scenario.network.layout)
        vehicle, sensor, traffic = scenario.vehicle, scenario.sensor, scenario.traffic
        reach = max(sensor.range, math.hypot(vehicle.length, vehicle.width / 2)) + 1.0
        self.grid = WallGrid.build(self.track.walls, reach)
        self.starts = start_poses(scenario, self.track)
        self.start = self.starts[0]
        self.traffic_starts = [tuple(xy) for xy in traffic.starts_xy]
        for index, (x, y) in enumerate(self.traffic_starts):
            if not self.track.contains(x, y):
                raise InputError(f"start ({x:g}, {y:g}) is off the drivable area",
                                 scenario.source, f"traffic.starts_xy[{index}]")
        self.vehicles = 1 + len(self.traffic_starts)
        self._shape = (
            np.asarray(scenario.layer_sizes, dtype=np.int64),
            math.radians(scenario.network.steering_gain_deg),
        )
        self._physics = Physics(
            vehicle.length,
            vehicle.width,
            vehicle.wheelbase,
            vehicle.speed * vehicle.dt,
            np.cos(scenario.beam_angles),
            np.sin(scenario.beam_angles),
            sensor.range,
            self.grid.walls,
            self.grid.lookup,
            np.asarray(self.track.bounds, dtype=np.float64),
            traffic.kernel_params(vehicle.wheelbase),
        )
        episode = scenario.episode
        self._limits = (episode.max_steps, episode.spin_window, episode.spin_variance)

    def episodes(self, generation: int) -> list[Episode]:
        """The traffic situations of a generation: one per (strategy, episode), drawn from
        (traffic seed, generation, strategy, episode) alone."""
        traffic = self.scenario.traffic
        key = self.traffic_key(generation)
        result = []
        for s, name in enumerate(traffic.strategy_list):
            for e in range(traffic.episodes):
                sequence = np.random.SeedSequence([traffic.seed, key, s, e])
                rng = np.random.default_rng(sequence)
                low, high = np.radians(traffic.start_heading_deg)
                start = np.array([self.start_of(key, s, e)] + [
                    (x, y, rng.uniform(low, high)) for x, y in self.traffic_starts])
                kind = kinematic.STRATEGIES.get(name, kinematic.NONE)
                kinds = np.array([kinematic.NONE] + [kind] * len(self.traffic_starts))
                genes = rng.uniform(-1, 1, size=(self.vehicles, self.spec.chromosome_length))
                result.append(Episode(start, kinds, self.spec.in_source_layout(genes),
                                      np.uint64(sequence.generate_state(1, np.uint64)[0])))
        return result

    def start_of(self, key: int, strategy: int, episode: int) -> tuple[float, float, float]:
        """The learner's start in the situation (traffic key, strategy, episode): the one
        start, or one drawn from the scenario's list of start lanes or edges."""
        if len(self.starts) == 1:
            return self.starts[0]
        sequence = [self.scenario.traffic.seed, key, strategy, episode, START_STREAM]
        return self.starts[np.random.default_rng(sequence).integers(len(self.starts))]

    def traffic_key(self, generation: int) -> int:
        """The key a generation's traffic is drawn from: its own, or 0 for every training
        generation when ``traffic.vary = "fixed"`` (held-out keys stay their own)."""
        fixed = self.scenario.traffic.vary == "fixed" and generation < HELD_OUT_KEYS
        return 0 if fixed else generation

    def episode_labels(self) -> list[str]:
        """The strategy of each column of :meth:`evaluate`'s per-episode arrays."""
        traffic = self.scenario.traffic
        return [name for name in traffic.strategy_list for _ in range(traffic.episodes)]

    def evaluate(self, population: np.ndarray, generation: int = 0) -> EpisodeResults:
        """Fitness of every chromosome: steps survived (0 for a spin), averaged over the
        generation's traffic situations."""
        genes = self.spec.in_source_layout(population)
        runs = []
        with numba.parallel_chunksize(1):
            for episode in self.episodes(generation):
                runs.append(run_population(
                    genes, *self._shape, episode.start, episode.kinds, episode.traffic_genes,
                    *self._physics, episode.seed, *self._limits))  # fmt: skip
        steps, outcome, suffered, near_steps, near_max = (
            np.stack([r[i] for r in runs], axis=1) for i in range(5))
        fitness = EpisodeResults.lifetime_fitness(steps, outcome).mean(axis=1)
        traffic = EpisodeResults.traffic_met(self.vehicles - 1, near_steps, near_max)
        return EpisodeResults(fitness, steps, outcome, suffered, self.vehicles, traffic)

    def trace(self, chromosome: np.ndarray, generation: int = 0, episode: int = 0,
              max_steps: int | None = None) -> tuple[np.ndarray, int]:
        """Poses (n, V, 3) of every vehicle in one episode, and the learner's outcome code."""
        limit = self._limits[0] if max_steps is None else max_steps
        chosen = self.episodes(generation)[episode]
        trace = np.full((limit + 1, self.vehicles, 3), np.nan)
        steps, outcome, *_ = run_episode(
            self.spec.in_source_layout(chromosome)[0], *self._shape, chosen.start, chosen.kinds,
            chosen.traffic_genes, *self._physics, chosen.seed, limit, *self._limits[1:], trace)
        return trace[: steps + 1], int(outcome)


def start_poses(scenario: Scenario, track: Track) -> list[tuple[float, float, float]]:
    """The learner's start poses (one, or one per listed start lane or edge), each checked to
    exist, allow passenger cars and lie on the drivable area."""
    config = scenario.track
    names = config.start_names
    key = "track.start_xy" if not names else f"track.start_{names[0][0]}"

    def where(index: int) -> str:
        listed = not isinstance(getattr(config, key.removeprefix("track.")), str)
        return f"{key}[{index}]" if names and listed else key

    if names:
        try:
            poses = start_lane_poses(config.net, names, config.start_offset)
        except ValueError as exc:
            index, message = exc.args
            raise InputError(message, scenario.source, where(index)) from None
    else:
        poses = [(*config.start_xy, math.radians(config.start_heading_deg))]
    for index, pose in enumerate(poses):
        if not track.contains(pose[0], pose[1]):
            raise InputError(f"start pose ({pose[0]:.1f}, {pose[1]:.1f}) is off the drivable "
                             f"area of {track.name}", scenario.source, where(index))
    return poses
