"""The arena and the navigation tracks: one learner per world, P worlds at once (paper §4–§5.4).

A world holds one learning vehicle (index 0), driven by the chromosome under evaluation, and
``V - 1`` uncontrolled vehicles driven by a traffic strategy
(:mod:`enn_traffic.sim.strategies`). Every evaluation resets the whole world to the same
start (§5.3). Each step applies the rules of :mod:`enn_traffic.sim.rules`:

1. blame: the learner's life ends at its first responsible collision; an uncontrolled vehicle
   that is responsible respawns at a free spot, and if it ran into the learner the learner's
   ``suffered`` count rises (a collision the learner did not cause);
2. the spin test (fitness 0) and the step cap, for the learner;
3. every vehicle senses and decides its steering; 4. every vehicle moves.

All P worlds of a generation run in one compiled call spread over the cores with ``prange``;
each world stops at its own end, and the call returns when all have.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np
from numba import njit, prange

from enn_traffic.config import Scenario
from enn_traffic.config.traffic import NETWORK, STRATEGIES
from enn_traffic.core import keys
from enn_traffic.core.errors import InputError
from enn_traffic.core.neural import NetworkSpec
from enn_traffic.roads import Track, load_track
from enn_traffic.roads.network import anywhere_poses, body_on_road, lane_start_poses
from enn_traffic.sim.rules import (
    NO_HIT,
    build_constants,
    copy_row,
    copy_rows,
    drive_all,
    drive_alone,
    life_columns,
    place,
    remember_bodies,
    respawn,
    responsible,
    spun,
    vehicles_at,
    wall_arrays,
    within_range,
    work_for,
)
from enn_traffic.sim.sensors import WallGrid
from enn_traffic.sim.strategies import reset_memory, strategy_settings
from enn_traffic.sim.world import CAPPED, COLLIDED, RUNNING, SPUN, SituationResults

START_STREAM = 5  # the last key of the seed that draws a situation's start from a list


# Columns of a world's tally (:func:`settle`): collisions the learner suffered, vehicle-steps
# within its sensor range, most vehicles within it at once, what it hit.
SUFFERED, NEAR_STEPS, NEAR_MAX, HIT = range(4)


@njit(cache=True)
def blame_traffic(kinds, vehicles, rng, physics, geometry, tally) -> None:
    """The blame rule for every uncontrolled vehicle: a responsible one respawns, and a
    collision with the learner counts in ``tally[SUFFERED]``. (Compiled on its own, not
    inlined: a kernel of the learner alone then never compiles it; :func:`alone`.)"""
    pose, corners, centres = vehicles.pose, vehicles.corners, vehicles.centres
    walls, cell_start, cell_walls, all_walls = wall_arrays(geometry)
    for v in range(1, pose.shape[0]):
        hit = responsible(v, pose, corners, centres, vehicles.previous,
                          vehicles.previous_centres, vehicles.fresh, v, physics, walls,
                          cell_start, cell_walls, all_walls)
        if hit == 0:
            tally[SUFFERED] += 1
        if hit != NO_HIT:
            respawn(v, kinds[v], physics, geometry, vehicles, rng)


@njit(cache=True, inline="always")
def settle(steps, kinds, vehicles, rng, recent, physics, geometry, max_steps, tally) -> int:
    """Steps 1–2 of the arena's step, after ``steps`` moves: the blame rule (the learner,
    vehicle 0, ends its life; a responsible uncontrolled vehicle respawns), then the learner's
    spin test and step cap, and the traffic it meets. Returns the learner's outcome, or
    ``RUNNING``; ``tally`` (``SUFFERED``, ``NEAR_STEPS``, ``NEAR_MAX``, ``HIT``) is updated."""
    pose, corners, centres = vehicles.pose, vehicles.corners, vehicles.centres
    previous, previous_centres, fresh = (vehicles.previous, vehicles.previous_centres,
                                         vehicles.fresh)
    walls, cell_start, cell_walls, all_walls = wall_arrays(geometry)
    hit = responsible(0, pose, corners, centres, previous, previous_centres, fresh, 0, physics,
                      walls, cell_start, cell_walls, all_walls)
    if hit != NO_HIT:
        tally[HIT] = hit
        return COLLIDED
    if kinds is not None and pose.shape[0] > 1:  # None: the learner alone (:func:`alone`)
        blame_traffic(kinds, vehicles, rng, physics, geometry, tally)
    if spun(recent, steps, pose[0, 0], pose[0, 1], physics.spin_variance):
        return SPUN
    if steps >= max_steps:
        return CAPPED
    within = within_range(pose[0, 0], pose[0, 1], centres, 1,
                          physics.max_range + physics.radius)
    tally[NEAR_STEPS] += within
    tally[NEAR_MAX] = max(tally[NEAR_MAX], within)
    return RUNNING


@njit(cache=True, inline="always")
def start_world(start, kinds, vehicles, rng, seed, physics, tally) -> None:
    """Every vehicle at its ``start`` pose with a fresh life, the world's generator at
    ``seed`` and the tally at zero (nothing hit)."""
    rng[0] = seed
    vehicles.fresh[:] = False
    for v in range(start.shape[0]):
        if kinds is not None:  # None: the learner alone, whose network keeps no memory
            reset_memory(kinds[v], physics, rng, vehicles.memory[v])
        place(v, start[v, 0], start[v, 1], start[v, 2], physics, vehicles.pose,
              vehicles.corners, vehicles.centres)
    remember_bodies(vehicles)
    tally[:] = 0
    tally[HIT] = NO_HIT


def alone(kinds: np.ndarray) -> np.ndarray | None:
    """What the kernels take as ``kinds``: None when vehicle 0, the learner, is the only
    vehicle. numba then compiles them without the traffic's rules (its branches on ``kinds is
    None`` are pruned by type), half the compile of the README's first run (docs/bench.md,
    First contact); the rules and the results are the same."""
    return None if len(kinds) == 1 else kinds


@njit(cache=True)
def run_life(genes, layer_sizes, start, kinds, traffic_genes, physics, geometry, seed, max_steps,
             trace):
    """Drive one chromosome (source layout) as vehicle 0 among ``start.shape[0] - 1``
    uncontrolled vehicles (``kinds``, None for none: :func:`alone`; ``traffic_genes`` drive the
    network ones) for one life.

    Returns (steps moved, outcome, collisions suffered, vehicle-steps within the learner's
    sensor range, most vehicles within it at once, what the learner hit: ``NO_HIT``,
    ``HIT_WALL`` or the vehicle's index). ``trace`` (n, V, 3) receives the poses of steps
    0..n-1 when n > 0.
    """
    count = start.shape[0]
    vehicles = vehicles_at(count)
    drivers = traffic_genes.copy()
    copy_row(genes, drivers[0])
    rng = np.empty(1, dtype=np.uint64)
    tally = np.empty(4, dtype=np.int64)
    work = work_for(geometry, layer_sizes, count)
    recent = np.empty((physics.spin_window, 2))
    start_world(start, kinds, vehicles, rng, seed, physics, tally)
    steps = 0
    while True:
        if steps < trace.shape[0]:
            copy_rows(vehicles.pose, trace[steps])
        outcome = settle(steps, kinds, vehicles, rng, recent, physics, geometry, max_steps,
                         tally)
        if outcome != RUNNING:
            return steps, outcome, tally[SUFFERED], tally[NEAR_STEPS], tally[NEAR_MAX], tally[HIT]
        # 3. sense and decide, 4. move
        if kinds is None:  # pruned by its type before the step's rules are inlined
            drive_alone(drivers, layer_sizes, physics, geometry, vehicles, work)
        else:
            drive_all(kinds, drivers, layer_sizes, physics, geometry, vehicles, rng, work)
        steps += 1


@njit(cache=True, parallel=True)
def run_population(population, layer_sizes, start, kinds, traffic_genes, physics, geometry, seed,
                   max_steps):
    """Run every chromosome of ``population`` (P, G) in its own world; per world
    (steps, outcome, collisions suffered, vehicle-steps within sensor range, most at once,
    what the learner hit)."""
    size = population.shape[0]
    steps, outcome, suffered, near_steps, near_max, hit = life_columns(size)
    no_trace = np.empty((0, start.shape[0], 3))
    for p in prange(size):
        steps[p], outcome[p], suffered[p], near_steps[p], near_max[p], hit[p] = run_life(
            population[p], layer_sizes, start, kinds, traffic_genes, physics, geometry, seed,
            max_steps, no_trace)
    return steps, outcome, suffered, near_steps, near_max, hit


@dataclass(frozen=True)
class Situation:
    """One traffic situation: every vehicle's start pose, strategy and (for random networks)
    genes, and the seed of the world's generator."""

    start: np.ndarray  # (V, 3)
    kinds: np.ndarray  # (V,)
    traffic_genes: np.ndarray  # (V, G), source layout
    seed: np.uint64


class LearnerWorld:
    """What every world of a rangefinder learner holds, whoever drives the traffic: the
    scenario, its track and wall grid, the learner's network and start poses, and the step's
    constants (:mod:`enn_traffic.sim.rules`). :class:`ArenaWorld` adds scripted traffic,
    :class:`~enn_traffic.sim.sumo.world.SumoWorld` SUMO's."""

    def __init__(self, scenario: Scenario):
        self.scenario = scenario
        listed = listed_starts(scenario)  # a wrong start lane is refused before any geometry
        self.track = load_track(scenario.track.net, exits=scenario.fringe_exits,
                                surface=scenario.track.surface)
        self.exits = self.track.exits if scenario.fringe_exits else np.empty((0, 4))
        self.spec = NetworkSpec(scenario.layer_sizes, scenario.network.layout)
        vehicle, traffic = scenario.vehicle, scenario.traffic
        reach = max(scenario.max_range, math.hypot(vehicle.length, vehicle.width / 2)) + 1.0
        try:
            self.grid = WallGrid.cached(self.track.walls, reach)
        except InputError as exc:  # the network's extent: name its file
            raise InputError(exc.message, scenario.track.net) from None
        self.starts = start_poses(scenario, self.track, listed)
        self.start = self.starts[0]
        self.layer_sizes = self.spec.layer_array
        episode = scenario.episode
        self.physics, self.geometry = build_constants(
            self.grid, self.track.bounds, scenario.beams, scenario.sensor.channels, self.exits,
            strategy_settings(traffic),
            length=vehicle.length,
            width=vehicle.width,
            wheelbase=vehicle.wheelbase,
            distance=vehicle.speed * vehicle.dt,
            dt=vehicle.dt,
            radius=0.5 * math.hypot(vehicle.length, vehicle.width),
            gain=math.radians(scenario.network.steering_gain_deg),
            spin_window=episode.spin_window,
            spin_variance=episode.spin_variance,
            clearance=traffic.respawn_clearance,
        )
        self.max_steps = episode.max_steps

    def start_of(self, key: int, strategy: int, index: int) -> tuple[float, float, float]:
        """The learner's start in the situation (traffic key, strategy, index): the one
        start, or one drawn from the scenario's list of start lanes or edges."""
        if len(self.starts) == 1:
            return self.starts[0]
        sequence = [self.scenario.traffic.seed, key, strategy, index, START_STREAM]
        return self.starts[np.random.default_rng(sequence).integers(len(self.starts))]

    def traffic_key(self, key: int) -> int:
        """The key traffic is drawn from: ``key``, or 0 for every training generation when
        ``traffic.vary = "fixed"`` (held-out keys stay their own)."""
        fixed = self.scenario.traffic.vary == "fixed" and keys.is_training(key)
        return 0 if fixed else key


class ArenaWorld(LearnerWorld):
    """A scenario's worlds: its track, learner and scripted traffic, ready to evaluate
    populations."""

    def __init__(self, scenario: Scenario):
        super().__init__(scenario)
        self.traffic_spec = NetworkSpec(scenario.traffic_layer_sizes, scenario.network.layout)
        self.traffic_starts = [tuple(xy) for xy in scenario.traffic.starts_xy]
        for index, (x, y) in enumerate(self.traffic_starts):
            if not self.track.contains(x, y):
                raise InputError(f"start ({x:g}, {y:g}) is off the drivable area",
                                 scenario.source, f"traffic.starts_xy[{index}]")
        self.vehicles = 1 + len(self.traffic_starts)

    def situations(self, key: int) -> list[Situation]:
        """The traffic situations of a traffic key: one per (strategy, index), drawn from
        (traffic seed, key, strategy, index) alone. The learner (vehicle 0) is a network
        driver."""
        traffic = self.scenario.traffic
        key = self.traffic_key(key)
        result = []
        for s, name in enumerate(traffic.strategy_list):
            for e in range(traffic.episodes):
                sequence = np.random.SeedSequence([traffic.seed, key, s, e])
                rng = np.random.default_rng(sequence)
                low, high = np.radians(traffic.start_heading_deg)
                start = np.array([self.start_of(key, s, e)] + [
                    (x, y, rng.uniform(low, high)) for x, y in self.traffic_starts])
                kind = STRATEGIES[name]
                kinds = np.array([NETWORK] + [kind] * len(self.traffic_starts))
                genes = rng.uniform(-1, 1, size=(self.vehicles,
                                                 self.traffic_spec.chromosome_length))
                if self.spec.holds(self.traffic_spec):
                    genes = self.spec.embed(genes, self.traffic_spec)
                else:  # no random-network traffic (the scenario's check): the genes go unused
                    genes = np.zeros((self.vehicles, self.spec.chromosome_length))
                result.append(Situation(start, kinds, genes,
                                      np.uint64(sequence.generate_state(1, np.uint64)[0])))
        return result

    def situation_labels(self) -> list[str]:
        """The strategy of each column of :meth:`evaluate`'s per-situation arrays."""
        traffic = self.scenario.traffic
        return [name for name in traffic.strategy_list for _ in range(traffic.episodes)]

    def evaluate(self, population: np.ndarray, key: int = 0) -> SituationResults:
        """Fitness of every chromosome: steps survived (0 for a spin), averaged over the
        traffic situations of ``key``."""
        genes = self.spec.in_source_layout(population)
        runs = []
        with numba.parallel_chunksize(1):
            for situation in self.situations(key):
                runs.append(run_population(
                    genes, self.layer_sizes, situation.start, alone(situation.kinds),
                    situation.traffic_genes, self.physics, self.geometry, situation.seed,
                    self.max_steps))
        return SituationResults.of_situations(runs, self.vehicles,
                                            [self.vehicles - 1] * len(runs))

    def trace(self, chromosome: np.ndarray, key: int = 0, situation: int = 0,
              max_steps: int | None = None) -> tuple[np.ndarray, int]:
        """Poses (n, V, 3) of every vehicle in one life (situation ``situation`` of traffic
        key ``key``), and the learner's outcome code."""
        limit = self.max_steps if max_steps is None else max_steps
        chosen = self.situations(key)[situation]
        trace = np.full((limit + 1, self.vehicles, 3), np.nan)
        steps, outcome, *_ = run_life(
            self.spec.in_source_layout(chromosome)[0], self.layer_sizes, chosen.start,
            alone(chosen.kinds), chosen.traffic_genes, self.physics, self.geometry, chosen.seed,
            limit, trace)
        return trace[: steps + 1], int(outcome)


def _start_key(scenario: Scenario, index: int) -> str:
    """The scenario key of the ``index``-th start: ``track.start_lane[1]``, ``track.start_xy``
    ..."""
    config = scenario.track
    names = config.start_names
    key = "track.start_xy" if not names else f"track.start_{names[0][0]}"
    listed = names and not isinstance(getattr(config, key.removeprefix("track.")), str)
    return f"{key}[{index}]" if listed else key


def listed_starts(scenario: Scenario) -> list[tuple[float, float, float]] | None:
    """The start poses that the scenario names (start lanes, edges or ``start_xy``), each
    checked to exist and allow passenger cars; None for ``start_anywhere``, whose starts need
    the drivable area. Reads the network only, so a wrong start is refused at once."""
    config = scenario.track
    if config.start_anywhere:
        return None
    names = config.start_names
    if not names:
        return [(*config.start_xy, math.radians(config.start_heading_deg))]
    try:
        return lane_start_poses(config.net, names, config.start_offset)
    except ValueError as exc:
        index, message = exc.args
        raise InputError(message, scenario.source, _start_key(scenario, index)) from None


def start_poses(scenario: Scenario, track: Track,
                listed: list[tuple[float, float, float]] | None = None
                ) -> list[tuple[float, float, float]]:
    """The learner's start poses (one, one per listed start lane or edge, or every start of
    ``start_anywhere``), each checked to exist, allow passenger cars and lie on the drivable
    area; ``listed``: the poses :func:`listed_starts` gave, when already read."""
    config = scenario.track
    if config.start_anywhere:
        vehicle = scenario.vehicle
        poses = anywhere_poses(config.net, track.area, vehicle.length, vehicle.width)
        if not poses:
            raise InputError(f"no lane of {track.name} has room for the vehicle",
                             scenario.source, "track.start_anywhere")
        return poses
    poses = listed if listed is not None else listed_starts(scenario)
    vehicle = scenario.vehicle
    for index, pose in enumerate(poses):
        if not track.contains(pose[0], pose[1]):
            raise InputError(f"start pose ({pose[0]:.1f}, {pose[1]:.1f}) is off the drivable "
                             f"area of {track.name}", scenario.source,
                             _start_key(scenario, index))
        if not body_on_road(track.area, pose, vehicle.length, vehicle.width):
            raise InputError(f"the learner's body at start pose ({pose[0]:.1f}, "
                             f"{pose[1]:.1f}), heading {math.degrees(pose[2]):.0f}°, reaches "
                             f"over the edge of {track.name}'s road surface: every life would "
                             "end at a wall at step 0 (a bend or a narrow lane there; try "
                             "another lane or start_offset)", scenario.source,
                             _start_key(scenario, index))
    return poses
