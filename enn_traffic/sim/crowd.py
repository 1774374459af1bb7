"""One arena where every vehicle drives by its own controller, and may learn while it drives
(paper §5.5; docs/design.md, "The authors' code" 6).

Unlike :mod:`enn_traffic.sim.arena`, which runs one learner per world and P worlds at once,
this is one world of V vehicles run for a stretch of simulated time, by the same rules
(:mod:`enn_traffic.sim.rules`). Each step:

1. :func:`crowd_events` — collisions by the blame rule, and the spin test for learning vehicles (and
   for every network vehicle when asked: evolved drivers are held to §5.3's rule that rotating
   in place ends a life);
2. every vehicle whose life ended respawns at a free spot; a learning vehicle first tells its
   learning (:class:`Learning`, e.g. :class:`enn_traffic.evolution.online.OnlineLearning`), which
   gives the chromosome of its next life;
3. every vehicle senses walls and the other bodies, decides and moves.

The steps run compiled (:func:`advance`) until a life ends; only then does Python respawn the
vehicle and call its learning back.

Collision rate (the metric of Tables 3–4): responsible collisions per second of simulated time,
per vehicle — all responsible collisions, each counted once for each vehicle responsible,
divided by the number of vehicles and the simulated time.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass
from typing import Protocol

import numpy as np
from numba import njit

from enn_traffic.kinds import NETWORK
from enn_traffic.neural import network_buffers
from enn_traffic.sim.arena import ArenaWorld
from enn_traffic.sim.rules import NO_HIT, drive_all, place, respawn, responsible, spun
from enn_traffic.sim.strategies import reset_memory
from enn_traffic.sim.world import COLLIDED, SPUN

ALIVE = -1


class Learning(Protocol):
    """What a crowd calls back for its learning vehicles. A life that reaches ``life_cap``
    steps (0: no cap) ends its chromosome's evaluation without a respawn."""

    life_cap: int

    def learns(self, vehicle: int) -> bool: ...

    def current(self, vehicle: int) -> np.ndarray:
        """The chromosome (source layout) the vehicle drives with now."""
        ...

    def life_ended(self, vehicle: int, steps: int, unseen_steps: int, spun: bool
                   ) -> np.ndarray:
        """A life of ``steps`` steps ended by a collision or a spin; the next chromosome."""
        ...

    def life_capped(self, vehicle: int, unseen_steps: int) -> np.ndarray:
        """The vehicle's life reached the cap; the chromosome it drives on with."""
        ...

    def still_driving(self, vehicle: int, unseen_steps: int) -> None:
        """The run ends with the vehicle's life going on."""
        ...


@njit(cache=True, inline="always")
def crowd_events(pose, corners, centres, previous, previous_centres, fresh, spin_checked, life,
                 recent, physics, walls, cell_start, cell_walls, all_walls, events) -> bool:
    """Fill ``events`` (V,): ``COLLIDED`` for a responsible collision, ``SPUN`` for a
    ``spin_checked`` vehicle spinning in place, else ``ALIVE``. Did any life end?"""
    ended = False
    for v in range(pose.shape[0]):
        events[v] = ALIVE
        if responsible(v, pose, corners, centres, previous, previous_centres, fresh, v, physics,
                       walls, cell_start, cell_walls, all_walls) != NO_HIT:
            events[v] = COLLIDED
        elif spin_checked[v] and spun(recent[v], life[v], pose[v, 0], pose[v, 1],
                                      physics.spin_variance):
            events[v] = SPUN
        ended = ended or events[v] != ALIVE
    return ended


@njit(cache=True, inline="always")
def step(kinds, genes, layer_sizes, physics, geometry, pose, corners, centres, previous,
         previous_centres, fresh, spin_checked, life, recent, memory, rng, readings, activation,
         scratch, steering, events) -> bool:
    """One step of the crowd: every vehicle senses, decides (an ``ACTION`` vehicle keeps the
    ``steering[v]`` it was given) and moves, then :func:`crowd_events`. Did any life end?"""
    beams, walls, cell_start = geometry.beams, geometry.walls, geometry.cell_start
    cell_walls, all_walls = geometry.cell_walls, geometry.all_walls
    drive_all(kinds, genes, layer_sizes, physics, beams, walls, cell_start,
              cell_walls, all_walls, pose, corners, centres, previous, previous_centres, fresh,
              memory, rng, readings, activation, scratch, steering)
    life += 1
    return crowd_events(pose, corners, centres, previous, previous_centres, fresh, spin_checked,
                        life, recent, physics, walls, cell_start, cell_walls, all_walls, events)


# The step alone, for a caller that steps from Python (the PettingZoo crowd, enn_traffic.envs).
step_once = njit(cache=True)(step.py_func)


@njit(cache=True)
def advance(t, last, drive_first, kinds, genes, layer_sizes, physics, geometry, pose, corners,
            centres, previous, previous_centres, fresh, spin_checked, life, recent, memory, rng,
            readings, activation, scratch, steering, events, trace) -> int:
    """Run the steps from ``t`` (driving first when ``drive_first``: the lives that ended at
    ``t`` have been dealt with) until a life ends or step ``last`` is reached: each step,
    :func:`step` (without ``drive_first``, only :func:`crowd_events` at ``t``) and record the poses
    in ``trace``. Returns the step it stopped at."""
    walls, cell_start, cell_walls = geometry.walls, geometry.cell_start, geometry.cell_walls
    all_walls = geometry.all_walls
    while True:
        if drive_first:
            ended = step(kinds, genes, layer_sizes, physics, geometry, pose, corners, centres,
                         previous, previous_centres, fresh, spin_checked, life, recent, memory,
                         rng, readings, activation, scratch, steering, events)
            t += 1
        else:
            ended = crowd_events(pose, corners, centres, previous, previous_centres, fresh,
                                 spin_checked, life, recent, physics, walls, cell_start,
                                 cell_walls, all_walls, events)
        drive_first = True
        trace[t] = pose
        if ended or t == last:
            return t


@dataclass
class CrowdRun:
    """What a stretch of simulated time produced."""

    collisions: np.ndarray  # (V,) responsible collisions per vehicle
    spins: np.ndarray  # (V,)
    seconds: float
    trace: np.ndarray  # (steps + 1, V, 3)

    @property
    def vehicle_steps(self) -> int:
        """Steps driven, summed over the vehicles."""
        return (self.trace.shape[0] - 1) * len(self.collisions)

    @property
    def collision_rate(self) -> float:
        """Responsible collisions per second of simulated time, per vehicle."""
        return float(self.collisions.sum()) / (len(self.collisions) * self.seconds)

    @property
    def spin_rate(self) -> float:
        """Spins in place per second of simulated time, per vehicle."""
        return float(self.spins.sum()) / (len(self.spins) * self.seconds)


class Crowd:
    """V vehicles in one arena: the scenario's learner start and traffic starts, each vehicle
    driven by genes of its own or by a scripted strategy (``kinds``). A vehicle whose life
    ends respawns at a random free spot, or with ``respawn_at_start`` at its own start pose
    with no check that it is free, as the authors' code does (reference §7.3)."""

    def __init__(self, world: ArenaWorld, starts: np.ndarray, kinds: np.ndarray, seed: int,
                 respawn_at_start: bool = False):
        self.world = world
        self.starts = np.asarray(starts, dtype=np.float64)
        self.respawn_at_start = respawn_at_start
        self.kinds = np.asarray(kinds, dtype=np.int64)
        count = len(self.kinds)
        self.physics = p = world.physics
        self.pose = np.empty((count, 3))
        self.corners = np.empty((count, 4, 2))
        self.centres = np.empty((count, 2))
        self.memory = np.zeros((count, 2))
        self.rng = np.full(1, np.uint64(seed), dtype=np.uint64)
        for v in range(count):
            place(v, *starts[v], p, self.pose, self.corners, self.centres)
            reset_memory(self.kinds[v], p, self.rng, self.memory[v])
        self.previous, self.previous_centres = self.corners.copy(), self.centres.copy()
        self.fresh = np.zeros(count, dtype=np.bool_)
        self.life = np.zeros(count, dtype=np.int64)
        self.recent = np.zeros((count, p.spin_window, 2))
        self.events = np.empty(count, dtype=np.int64)
        self.geometry = world.geometry
        self._work = (np.empty(len(self.geometry.beams)), *network_buffers(world.layer_sizes),
                      np.zeros(count))

    @property
    def steering(self) -> np.ndarray:
        """(V,) each vehicle's steering: an ``ACTION`` vehicle's is set before a step."""
        return self._work[3]

    def respawn(self, v: int) -> None:
        """Vehicle ``v`` starts a new life at a free spot
        (:func:`~enn_traffic.sim.rules.respawn`), or at its start pose."""
        self.life[v] = 0
        if self.respawn_at_start:
            place(v, *self.starts[v], self.physics, self.pose, self.corners, self.centres)
            self.previous[v], self.previous_centres[v] = self.corners[v], self.centres[v]
            self.fresh[v] = True
            reset_memory(self.kinds[v], self.physics, self.rng, self.memory[v])
            return
        walls, cell_start = self.geometry.walls, self.geometry.cell_start
        cell_walls, all_walls = self.geometry.cell_walls, self.geometry.all_walls
        respawn(v, self.kinds[v], self.physics, walls, cell_start, cell_walls, all_walls,
                self.pose, self.corners, self.centres, self.previous, self.previous_centres,
                self.fresh, self.memory, self.rng)

    def fork(self) -> Crowd:
        """A crowd in this one's state (poses, lives, memories, random generator) that goes on
        apart from it; the world is shared."""
        twin = copy.copy(self)
        for name, value in vars(self).items():
            if isinstance(value, np.ndarray):
                setattr(twin, name, value.copy())
        twin._work = tuple(buffer.copy() for buffer in self._work)
        return twin

    def remove(self, vehicles) -> None:
        """The ``vehicles`` leave the arena; the others keep their order."""
        for name in ("kinds", "pose", "corners", "centres", "memory", "previous",
                     "previous_centres", "fresh", "life", "recent", "events"):
            setattr(self, name, np.delete(getattr(self, name), vehicles, axis=0))
        readings, activation, scratch, steering = self._work
        self._work = (readings, activation, scratch, np.delete(steering, vehicles))

    def run(self, seconds: float, genes: np.ndarray, learning: Learning | None = None,
            check_spins: bool = False) -> CrowdRun:
        """Drive for ``seconds`` of simulated time. ``genes`` (V, G, source layout) drive the
        network vehicles; a vehicle that ``learning`` learns drives with its current
        chromosome, and its learning hears of every life it ends and every life that reaches
        its cap. Learning vehicles, and with ``check_spins`` every network vehicle, lose their
        life when they spin in place."""
        count = len(self.kinds)
        learns = [learning is not None and learning.learns(v) for v in range(count)]
        spin_checked = np.array(learns) | (check_spins & (self.kinds == NETWORK))
        unseen_from = self.life.copy()  # steps of a life going on that an earlier run showed
        for v in np.flatnonzero(learns):
            genes[v] = learning.current(v)
        steps = round(seconds / self.world.scenario.vehicle.dt)
        collisions, spins = np.zeros(count, dtype=np.int64), np.zeros(count, dtype=np.int64)
        trace = np.empty((steps + 1, count, 3))
        p, geometry = self.physics, self.geometry
        t, drive_first = 0, False
        learners = np.flatnonzero(learns)
        cap = learning.life_cap if learning is not None and len(learners) else 0
        while True:
            # stop too when the oldest learning life reaches the cap
            last = steps if not cap else min(steps, t + cap - int(self.life[learners].max()))
            t = advance(t, last, drive_first, self.kinds, genes, self.world.layer_sizes, p,
                        geometry, self.pose, self.corners, self.centres, self.previous,
                        self.previous_centres, self.fresh, spin_checked, self.life, self.recent,
                        self.memory, self.rng, *self._work, self.events, trace)
            for v in np.flatnonzero(self.events != ALIVE):
                spun = bool(self.events[v] == SPUN)
                spins[v] += spun
                collisions[v] += not spun
                if learns[v]:
                    genes[v] = learning.life_ended(v, int(self.life[v]),
                                                   int(self.life[v] - unseen_from[v]), spun)
                unseen_from[v] = 0
                self.respawn(v)
            for v in learners[self.life[learners] >= cap] if cap else ():
                genes[v] = learning.life_capped(v, int(self.life[v] - unseen_from[v]))
                unseen_from[v] = self.life[v] = 0
            if t == steps:
                break
            drive_first = True
        for v in np.flatnonzero(learns):  # a life still going counts what it has shown
            learning.still_driving(v, int(self.life[v] - unseen_from[v]))
        return CrowdRun(collisions, spins, steps * self.world.scenario.vehicle.dt, trace)
