"""Batched worlds and the episode loop (paper §4–§5.1).

One world is one vehicle driven by one chromosome on one track. Every chromosome starts from the
same pose (the whole world is reset per evaluation, §5.3). Each step: sense at the current pose,
decide the steering, check for a collision, then move. A world ends at its first collision,
when it spins (the position variance over the last ``spin_window`` poses is at most
``spin_variance`` on both axes: fitness 0, §5.3), or at the step cap.

All P worlds of a generation run in one compiled call, spread over the CPU cores with ``prange``;
each world stops at its own end (its lane of the done-mask), and the call returns when all have.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np
from numba import njit, prange

from enn_traffic.evolution.genome import NetworkSpec
from enn_traffic.roads import Track, load_track
from enn_traffic.scenario import Scenario
from enn_traffic.sim.collide import body_corners, box_hits_walls
from enn_traffic.sim.kinematics import bicycle_step
from enn_traffic.sim.sensors import WallGrid, nearby_walls, sense_walls

# How an episode ended.
CAPPED, COLLIDED, SPUN = 0, 1, 2
OUTCOMES = {CAPPED: "capped", COLLIDED: "collision", SPUN: "spin"}


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
def run_episode(
    genes, layer_sizes, gain, x, y, heading,
    length, width, wheelbase, distance, beam_cos, beam_sin, max_range,
    walls, origin, cell_size, nx, ny, cell_start, cell_walls, all_walls,
    max_steps, spin_window, spin_variance, trace,
):  # fmt: skip
    """Drive one chromosome from the start pose; return (steps moved, outcome).

    ``trace`` (n, 3) receives the poses 0..n-1 when n > 0.
    """
    readings = np.empty(beam_cos.shape[0])
    width_max = layer_sizes.max()
    activation = np.empty(width_max)
    scratch = np.empty(width_max)
    corners = np.empty((4, 2))
    recent = np.empty((spin_window, 2))
    steps = 0
    while True:
        if steps < trace.shape[0]:
            trace[steps, 0], trace[steps, 1], trace[steps, 2] = x, y, heading
        candidates = nearby_walls(
            x, y, origin, cell_size, nx, ny, cell_start, cell_walls, all_walls
        )
        sense_walls(x, y, heading, beam_cos, beam_sin, max_range, walls, candidates, readings)
        steering = network_steering(genes, layer_sizes, readings, activation, scratch, gain)
        body_corners(x, y, heading, length, width, corners)
        if box_hits_walls(corners, walls, candidates, candidates.shape[0]):
            return steps, COLLIDED
        slot = steps % spin_window
        recent[slot, 0], recent[slot, 1] = x, y
        if steps + 1 >= spin_window and _small_spread(recent, spin_variance):
            return steps, SPUN
        if steps >= max_steps:
            return steps, CAPPED
        x, y, heading = bicycle_step(x, y, heading, steering, distance, wheelbase)
        steps += 1


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
    population, layer_sizes, gain, x, y, heading,
    length, width, wheelbase, distance, beam_cos, beam_sin, max_range,
    walls, origin, cell_size, nx, ny, cell_start, cell_walls, all_walls,
    max_steps, spin_window, spin_variance,
):  # fmt: skip
    """Run every chromosome of ``population`` (P, G) to its end; (steps, outcome) per world."""
    count = population.shape[0]
    steps = np.zeros(count, dtype=np.int64)
    outcome = np.zeros(count, dtype=np.int64)
    no_trace = np.empty((0, 3))
    for p in prange(count):
        steps[p], outcome[p] = run_episode(
            population[p], layer_sizes, gain, x, y, heading,
            length, width, wheelbase, distance, beam_cos, beam_sin, max_range,
            walls, origin, cell_size, nx, ny, cell_start, cell_walls, all_walls,
            max_steps, spin_window, spin_variance, no_trace,
        )  # fmt: skip
    return steps, outcome


@dataclass(frozen=True)
class EpisodeResults:
    """Per world: fitness, steps moved, and how the episode ended (``OUTCOMES``)."""

    fitness: np.ndarray
    steps: np.ndarray
    outcome: np.ndarray

    @property
    def vehicle_steps(self) -> int:
        return int(self.steps.sum())


class NavigationWorld:
    """One learning vehicle alone on a SUMO track (paper §5.1–5.2)."""

    def __init__(self, scenario: Scenario, track: Track | None = None):
        self.scenario = scenario
        self.track = track or load_track(scenario.track.net)
        self.spec = NetworkSpec(scenario.layer_sizes, scenario.network.layout)
        vehicle, sensor = scenario.vehicle, scenario.sensor
        reach = max(sensor.range, math.hypot(vehicle.length, vehicle.width / 2)) + 1.0
        self.grid = WallGrid.build(self.track.walls, reach)
        self.start = start_pose(scenario, self.track)
        self._order = self.spec.source_order()
        self._constants = (
            np.asarray(scenario.layer_sizes, dtype=np.int64),
            math.radians(scenario.network.steering_gain_deg),
            *self.start,
            vehicle.length,
            vehicle.width,
            vehicle.wheelbase,
            vehicle.speed * vehicle.dt,
            np.cos(scenario.beam_angles),
            np.sin(scenario.beam_angles),
            sensor.range,
            *self.grid.kernel_args(),
        )
        episode = scenario.episode
        self._limits = (episode.max_steps, episode.spin_window, episode.spin_variance)

    def _genes(self, population: np.ndarray) -> np.ndarray:
        population = np.atleast_2d(np.asarray(population, dtype=np.float64))
        if population.shape[1] != self.spec.chromosome_length:
            raise ValueError(
                f"chromosomes have {population.shape[1]} genes; the network "
                f"{self.spec.layer_sizes} needs {self.spec.chromosome_length}"
            )
        return np.ascontiguousarray(population[:, self._order])

    def evaluate(self, population: np.ndarray) -> EpisodeResults:
        """Fitness of every chromosome: steps survived, 0 for a spin."""
        with numba.parallel_chunksize(1):
            steps, outcome = run_population(
                self._genes(population), *self._constants, *self._limits
            )
        fitness = np.where(outcome == SPUN, 0, steps).astype(np.float64)
        return EpisodeResults(fitness=fitness, steps=steps, outcome=outcome)

    def trace(self, chromosome: np.ndarray, max_steps: int | None = None) -> tuple[np.ndarray, int]:
        """Poses (n, 3) of one episode and its outcome code."""
        limit = self._limits[0] if max_steps is None else max_steps
        trace = np.full((limit + 1, 3), np.nan)
        steps, outcome = run_episode(
            self._genes(chromosome)[0], *self._constants, limit, *self._limits[1:], trace
        )
        return trace[: steps + 1], int(outcome)


def start_pose(scenario: Scenario, track: Track) -> tuple[float, float, float]:
    """The scenario's start pose, checked to lie on the drivable area."""
    from enn_traffic.errors import InputError

    config = scenario.track
    if config.start_lane is not None:
        pose = track.lane_pose(config.net, config.start_lane, config.start_offset)
    else:
        pose = (*config.start_xy, math.radians(config.start_heading_deg))
    if not track.contains(pose[0], pose[1]):
        raise InputError(
            f"start pose ({pose[0]:.1f}, {pose[1]:.1f}) is off the drivable area of {track.name}",
            scenario.source,
            "track.start_xy" if config.start_lane is None else "track.start_lane",
        )
    return pose
