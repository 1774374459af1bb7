"""Many arena or navigation worlds stepped by one compiled call, the learner of each driven
by an action from outside (:mod:`enn_traffic.envs.rangefinder`).

A world here is the GA's world (:func:`enn_traffic.sim.arena.run_life`) with its learner's
steering given instead of computed: the same situations (:meth:`ArenaWorld.situations`), the
same :func:`~enn_traffic.sim.arena.start_world`, :func:`~enn_traffic.sim.arena.settle` and
:func:`~enn_traffic.sim.rules.drive_all`, in the same order, so that a network's outputs fed
as actions drive the GA's trajectory step for step. An action is the paper's two network
outputs (§3): steering = gain · (``action[1]`` − ``action[0]``).

The worlds' arrays lead with the world: ``pose[i]`` is world ``i``'s (V, 3) poses. The
situations a world may drive are a pool (:class:`Situations`); when a life ends the world
starts the next situation of the pool in turn (world ``i`` of N drives situations ``i``,
``i + N``, ``i + 2N``, ... modulo the pool's size).
"""

from __future__ import annotations

from typing import NamedTuple

import numba
import numpy as np
from numba import njit, prange

from enn_traffic.config.traffic import ACTION
from enn_traffic.core.progress import slow_step
from enn_traffic.sim.arena import ArenaWorld, settle, start_world
from enn_traffic.sim.readings import reading_count, seen_for, work_row
from enn_traffic.sim.rules import Vehicles, Work, copy_row, copy_rows, drive_all, wall_arrays
from enn_traffic.sim.sensors import sense
from enn_traffic.sim.world import RUNNING, SPUN


class Situations(NamedTuple):
    """A pool of M traffic situations: start poses (M, V, 3), drivers (M, V) and their genes
    (M, V, G, source layout), and each world generator's seed (M,)."""

    start: np.ndarray
    kinds: np.ndarray
    genes: np.ndarray
    seed: np.ndarray

    @classmethod
    def of_keys(cls, world: ArenaWorld, keys) -> Situations:
        """Every situation of the traffic ``keys``, in order (each key's strategies and
        situations, as :meth:`ArenaWorld.situations` gives them), the learner an ``ACTION``."""
        chosen = [situation for key in keys for situation in world.situations(int(key))]
        kinds = np.stack([e.kinds for e in chosen]).astype(np.int64)
        kinds[:, 0] = ACTION
        return cls(np.stack([e.start for e in chosen]), kinds,
                   np.ascontiguousarray(np.stack([e.traffic_genes for e in chosen])),
                   np.array([e.seed for e in chosen], dtype=np.uint64))


class Worlds(NamedTuple):
    """The state of N worlds of V vehicles with B beams: the GA's per-world arrays
    (:func:`~enn_traffic.sim.arena.run_life`) with a leading world axis, each world's
    situation, the learner's observation and what the last step gave."""

    kinds: np.ndarray  # (N, V)
    drivers: np.ndarray  # (N, V, G)
    pose: np.ndarray  # (N, V, 3)
    corners: np.ndarray  # (N, V, 4, 2)
    centres: np.ndarray  # (N, V, 2)
    previous: np.ndarray
    previous_centres: np.ndarray
    fresh: np.ndarray  # (N, V)
    memory: np.ndarray  # (N, V, 2)
    rng: np.ndarray  # (N, 1)
    recent: np.ndarray  # (N, spin_window, 2)
    steps: np.ndarray  # (N,) steps moved in the life going on
    tally: np.ndarray  # (N, 4): suffered, near steps, near max, hit (arena.SUFFERED, ...)
    steering: np.ndarray  # (N, V)
    readings: np.ndarray  # (N, B) work array: every vehicle's readings
    seen: np.ndarray | None  # (N, B, 2) work array: what its beams met (readings.seen_for)
    activation: np.ndarray  # (N, width) the traffic networks' work arrays
    scratch: np.ndarray
    situation: np.ndarray  # (N,) index into the pool
    observation: np.ndarray  # (N, B) the learner's readings
    reward: np.ndarray  # (N,)
    outcome: np.ndarray  # (N,) RUNNING, or how the life ended
    life: np.ndarray  # (N,) steps of the life that ended (fitness, with outcome)
    final_observation: np.ndarray  # (N, B) the learner's readings when its life ended
    final_tally: np.ndarray  # (N, 4)

    @classmethod
    def empty(cls, count: int, world: ArenaWorld, genes: int) -> Worlds:
        """Room for ``count`` worlds of ``world`` whose drivers have ``genes`` genes."""
        vehicles, beams = world.vehicles, reading_count(world.geometry)
        seen = seen_for(world.geometry.beams, world.geometry.channels)
        width = max(int(world.layer_sizes.max()), 2)
        shape = (count, vehicles)
        return cls(
            np.zeros(shape, np.int64), np.zeros((*shape, genes)), np.zeros((*shape, 3)),
            np.zeros((*shape, 4, 2)), np.zeros((*shape, 2)), np.zeros((*shape, 4, 2)),
            np.zeros((*shape, 2)), np.zeros(shape, np.bool_), np.zeros((*shape, 2)),
            np.zeros((count, 1), np.uint64), np.zeros((count, world.physics.spin_window, 2)),
            np.zeros(count, np.int64), np.zeros((count, 4), np.int64), np.zeros(shape),
            np.zeros((count, beams)), None if seen is None else np.zeros((count, *seen.shape)),
            np.zeros((count, width)), np.zeros((count, width)),
            np.zeros(count, np.int64), np.zeros((count, beams)), np.zeros(count),
            np.full(count, RUNNING, np.int64), np.zeros(count, np.int64),
            np.zeros((count, beams)), np.zeros((count, 4), np.int64))


@njit(cache=True, inline="always")
def world_vehicles(worlds, i):
    """World ``i``'s vehicles (:class:`~enn_traffic.sim.rules.Vehicles`), views into
    ``worlds``: a record of records cannot enter a compiled parallel loop, so
    :class:`Worlds` stays flat."""
    return Vehicles(worlds.pose[i], worlds.corners[i], worlds.centres[i], worlds.previous[i],
                    worlds.previous_centres[i], worlds.fresh[i], worlds.memory[i])


@njit(cache=True, inline="always")
def world_work(worlds, i):
    """World ``i``'s work arrays (:class:`~enn_traffic.sim.rules.Work`), views into
    ``worlds``."""
    return Work(worlds.readings[i], work_row(worlds.seen, i), worlds.activation[i],
                worlds.scratch[i], worlds.steering[i])


@njit(cache=True, inline="always")
def observe(vehicles, physics, geometry, out, seen):
    """The learner (vehicle 0) senses walls and the other bodies into ``out`` (``seen``: a
    :func:`~enn_traffic.sim.readings.seen_for` work array)."""
    walls, cell_start, cell_walls, all_walls = wall_arrays(geometry)
    sense(0, vehicles.pose, physics, geometry.beams, geometry.channels, walls, cell_start,
          cell_walls, all_walls, vehicles.pose.shape[0] > 1, vehicles.corners, vehicles.centres,
          vehicles.previous_centres, 0, out, seen)


@njit(cache=True)
def begin(i, m, pool, worlds, physics, geometry, max_steps):
    """World ``i`` of ``worlds`` (:class:`Worlds`) starts situation ``m`` of ``pool``
    (:class:`Situations`): step 0's rules, then the learner's first observation. (Called,
    not inlined, in the parallel loops: numba's parallel passes, given the inlined body of a
    world, compiled writes that were lost, or not, by the order the kernels compiled in.)"""
    vehicles = world_vehicles(worlds, i)
    copy_row(pool.kinds[m], worlds.kinds[i])
    copy_rows(pool.genes[m], worlds.drivers[i])
    worlds.situation[i] = m
    worlds.steps[i] = 0
    start_world(pool.start[m], worlds.kinds[i], vehicles, worlds.rng[i], pool.seed[m], physics,
                worlds.tally[i])
    settle(0, worlds.kinds[i], vehicles, worlds.rng[i], worlds.recent[i], physics, geometry,
           max_steps, worlds.tally[i])
    observe(vehicles, physics, geometry, worlds.observation[i], work_row(worlds.seen, i))


@njit(cache=True)
def step_world(i, action, autoreset, pool, worlds, layer_sizes, physics, geometry, max_steps):
    """World ``i`` steps with its learner's ``action`` (:func:`step_worlds`)."""
    vehicles, work = world_vehicles(worlds, i), world_work(worlds, i)
    steps, outcome = worlds.steps, worlds.outcome
    work.steering[0] = physics.gain * (action[1] - action[0])
    drive_all(worlds.kinds[i], worlds.drivers[i], layer_sizes, physics, geometry, vehicles,
              worlds.rng[i], work)
    steps[i] += 1
    outcome[i] = settle(steps[i], worlds.kinds[i], vehicles, worlds.rng[i], worlds.recent[i],
                        physics, geometry, max_steps, worlds.tally[i])
    observe(vehicles, physics, geometry, worlds.observation[i], work_row(worlds.seen, i))
    worlds.reward[i] = 1.0
    if outcome[i] == RUNNING:
        return
    if outcome[i] == SPUN:
        worlds.reward[i] = 1.0 - steps[i]
    worlds.life[i] = steps[i]
    copy_row(worlds.observation[i], worlds.final_observation[i])
    copy_row(worlds.tally[i], worlds.final_tally[i])
    if autoreset:
        begin(i, (worlds.situation[i] + worlds.pose.shape[0]) % pool.seed.shape[0], pool, worlds,
              physics, geometry, max_steps)


@njit(cache=True, parallel=True)
def begin_worlds(first, pool, worlds, physics, geometry, max_steps):
    """Every world ``i`` of ``worlds`` starts situation ``(first + i) % M`` of ``pool``."""
    count, size = worlds.pose.shape[0], pool.seed.shape[0]
    for i in prange(count):
        w = np.int64(i)  # one type for the callee (a parallel loop's index is unsigned)
        begin(w, (first + w) % size, pool, worlds, physics, geometry, max_steps)


@njit(cache=True, parallel=True)
def step_worlds(actions, autoreset, pool, worlds, layer_sizes, physics, geometry, max_steps):
    """One step of every world of ``worlds`` (:class:`Worlds`, N, spread over the cores): each
    learner steers by its action (N, 2), every vehicle senses, decides and moves, then the
    rules of :func:`~enn_traffic.sim.arena.settle`. ``reward`` is 1 per step lived, and a spin
    takes back the life's steps, so that a life's return is the paper's fitness (§5, §5.3). A
    world whose life ended keeps its learner's last readings in ``final_observation`` and,
    with ``autoreset``, starts its next situation of ``pool``."""
    for i in prange(worlds.pose.shape[0]):
        # numba types the loop once with a signed index and compiles it again with the
        # parallel loop's unsigned one: as one type, the callee compiles once, not twice
        w = np.int64(i)
        step_world(w, actions[w], autoreset, pool, worlds, layer_sizes, physics, geometry,
                   max_steps)


# The same two kernels, run on one thread: a parallel call's start costs more than a single
# world's step (the single environment, gymnasium's SyncVectorEnv of it).
begin_one = njit(cache=True)(begin_worlds.py_func)
step_one = njit(cache=True)(step_worlds.py_func)


def compiled(function, *args):
    """``function`` compiled for the types of ``args``, called directly: through numba's
    dispatcher a call that takes :class:`~enn_traffic.sim.rules.Physics` (a NamedTuple of
    more than 10 fields) is typed on its slow path every time (numba issue 6144)."""
    with slow_step("compiling the environment's kernels (once per install, edit of the kernels or "
                   "new cache folder; kept in numba's cache folder)"):
        return function.compile(tuple(numba.typeof(value) for value in args))


class Batch:
    """N worlds of a scenario's :class:`ArenaWorld`, started and stepped in one compiled
    call each."""

    def __init__(self, world: ArenaWorld, count: int):
        self.world = world
        self.count = count
        self.max_steps = world.max_steps
        self.genes = world.traffic_spec.chromosome_length
        self.worlds = Worlds.empty(count, world, world.spec.chromosome_length)
        self.pool: Situations | None = None
        self._begin = self._step = None

    def __getstate__(self) -> dict:
        """Picklable: the compiled kernels are compiled again where it is unpickled."""
        return {**self.__dict__, "_begin": None, "_step": None}

    def begin(self, pool: Situations, first: int = 0) -> None:
        """Every world starts a situation of ``pool``: world ``i`` the ``(first + i)``-th."""
        if pool.genes.shape[2] != self.worlds.drivers.shape[2]:
            raise ValueError("the pool's drivers have another number of genes")
        self.pool = pool
        w = self.worlds
        args = (first, pool, w, self.world.physics, self.world.geometry, self.max_steps)
        if self._begin is None:
            self._begin = compiled(begin_one if self.count == 1 else begin_worlds, *args)
        self._begin(*args)
        w.outcome[:] = RUNNING

    def step(self, actions: np.ndarray, autoreset: bool) -> None:
        """Every world steps with its learner's action (N, 2)."""
        w = self.worlds
        args = (np.ascontiguousarray(actions, dtype=np.float64), autoreset, self.pool, w,
                self.world.layer_sizes, self.world.physics, self.world.geometry, self.max_steps)
        if self._step is None:
            self._step = compiled(step_one if self.count == 1 else step_worlds, *args)
        self._step(*args)
