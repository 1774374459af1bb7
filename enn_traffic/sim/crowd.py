"""One arena where every vehicle drives by its own controller, and may learn while it drives
(paper §5.5; docs/design.md, "The authors' code" 6).

Unlike :mod:`enn_traffic.sim.arena`, which runs one learner per world and P worlds at once,
this is one world of V vehicles run for a stretch of simulated time, by the same rules
(:mod:`enn_traffic.sim.rules`). Each step:

1. :func:`crowd_events` — collisions by the blame rule, and the spin test for learning vehicles (and
   for every network vehicle when asked: evolved drivers are held to §5.3's rule that rotating
   in place ends a life);
2. every vehicle whose life ended respawns at a free spot; a learning vehicle first tells its
   learning (:class:`Learning`, e.g. :class:`enn_traffic.learning.online.OnlineLearning`), which
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
from typing import NamedTuple, Protocol

import numpy as np
from numba import njit

from enn_traffic.config.traffic import NETWORK
from enn_traffic.sim.arena import ArenaWorld
from enn_traffic.sim.rules import (
    NO_HIT,
    copy_rows,
    drive_all,
    enter,
    place,
    remember_bodies,
    respawn,
    responsible,
    spun,
    vehicles_at,
    wall_arrays,
    work_for,
)
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

    def still_driving(self, vehicle: int, unseen_steps: int, life_steps: int) -> None:
        """The run ends with the vehicle's life going on, ``life_steps`` long."""
        ...


class Lives(NamedTuple):
    """The crowd's vehicles' lives, one row each (V): whether the spin test applies, steps
    lived, the last positions for the spin test, and what the last step ended (``ALIVE``,
    ``COLLIDED`` or ``SPUN``)."""

    spin_checked: np.ndarray  # (V,) bool
    life: np.ndarray  # (V,)
    recent: np.ndarray  # (V, spin_window, 2)
    events: np.ndarray  # (V,)


@njit(cache=True, inline="always")
def crowd_events(vehicles, lives, physics, geometry) -> bool:
    """Fill ``lives.events``: ``COLLIDED`` for a responsible collision, ``SPUN`` for a
    ``spin_checked`` vehicle spinning in place, else ``ALIVE``. Did any life end?"""
    pose, corners, centres = vehicles.pose, vehicles.corners, vehicles.centres
    previous, previous_centres, fresh = (vehicles.previous, vehicles.previous_centres,
                                         vehicles.fresh)
    spin_checked, life, recent, events = lives.spin_checked, lives.life, lives.recent, lives.events
    walls, cell_start, cell_walls, all_walls = wall_arrays(geometry)
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
def step(kinds, genes, layer_sizes, physics, geometry, vehicles, lives, rng, work,
         blame_current) -> bool:
    """One step of the crowd: every vehicle senses, decides (an ``ACTION`` vehicle keeps the
    ``work.steering[v]`` it was given) and moves, then :func:`crowd_events`; with
    ``blame_current`` the blame tests every body against the others' bodies after the move,
    not before it (the authors' code after a reset, reference §7.3). Did any life end?"""
    drive_all(kinds, genes, layer_sizes, physics, geometry, vehicles, rng, work)
    if blame_current:
        remember_bodies(vehicles)
    life = lives.life
    life += 1
    return crowd_events(vehicles, lives, physics, geometry)


# The step alone, for a caller that steps from Python (the PettingZoo crowd, enn_traffic.envs).
step_once = njit(cache=True)(step.py_func)


@njit(cache=True)
def advance(t, last, drive_first, blame_current, kinds, genes, layer_sizes, physics, geometry,
            vehicles, lives, rng, work, trace) -> int:
    """Run the steps from ``t`` (driving first when ``drive_first``: the lives that ended at
    ``t`` have been dealt with) until a life ends or step ``last`` is reached: each step,
    :func:`step` (without ``drive_first``, only :func:`crowd_events` at ``t``) and record the poses
    in ``trace``. ``blame_current``: the first step's (:func:`step`). Returns the step it
    stopped at."""
    while True:
        if drive_first:
            ended = step(kinds, genes, layer_sizes, physics, geometry, vehicles, lives, rng, work,
                         blame_current)
            t += 1
        else:
            ended = crowd_events(vehicles, lives, physics, geometry)
        drive_first, blame_current = True, False
        copy_rows(vehicles.pose, trace[t])
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

    def rate(self, counting: str = "responsible") -> float:
        """The rate of Tables 3–4 by the scenario's ``[crowd] counting``: ``responsible``,
        :attr:`collision_rate`; ``lives_lost``, lives lost (collisions and spins) of all
        vehicles together per second, the paper's unit."""
        if counting == "lives_lost":
            return float(self.collisions.sum() + self.spins.sum()) / self.seconds
        return self.collision_rate


class Crowd:
    """V vehicles in one arena: the scenario's learner start and traffic starts, each vehicle
    driven by genes of its own or by a scripted strategy (``kinds``). A vehicle whose life
    ends respawns at a random free spot, or with ``respawn_at_start`` at its own start pose
    with no check that it is free, as the authors' code does (reference §7.3). With
    ``blame_all_after_respawn``, the step after any respawn tests every vehicle against the
    others' current bodies, as the authors' code does (it clears every car's previous body,
    reference §7.3); by default only the respawned vehicle starts with no earlier body."""

    def __init__(self, world: ArenaWorld, starts: np.ndarray, kinds: np.ndarray, seed: int,
                 respawn_at_start: bool = False, blame_all_after_respawn: bool = False):
        self.world = world
        self.starts = np.asarray(starts, dtype=np.float64)
        self.respawn_at_start = respawn_at_start
        self.blame_all_after_respawn = blame_all_after_respawn
        self.kinds = np.asarray(kinds, dtype=np.int64)
        count = len(self.kinds)
        self.physics = p = world.physics
        self.rng = np.full(1, np.uint64(seed), dtype=np.uint64)
        self.vehicles = vehicles = vehicles_at(count)
        for v in range(count):
            place(v, *starts[v], p, vehicles.pose, vehicles.corners, vehicles.centres)
            reset_memory(self.kinds[v], p, self.rng, vehicles.memory[v])
        vehicles.previous[:], vehicles.previous_centres[:] = vehicles.corners, vehicles.centres
        self.lives = Lives(np.zeros(count, dtype=np.bool_), np.zeros(count, dtype=np.int64),
                           np.zeros((count, p.spin_window, 2)), np.empty(count, dtype=np.int64))
        self.geometry = world.geometry
        self.work = work_for(self.geometry, world.layer_sizes, count)

    @property
    def pose(self) -> np.ndarray:
        """(V, 3) every vehicle's pose."""
        return self.vehicles.pose

    @property
    def corners(self) -> np.ndarray:
        """(V, 4, 2) every vehicle's body."""
        return self.vehicles.corners

    def respawn(self, v: int) -> None:
        """Vehicle ``v`` starts a new life at a free spot
        (:func:`~enn_traffic.sim.rules.respawn`), or at its start pose."""
        self.lives.life[v] = 0
        if self.respawn_at_start:
            enter(v, *self.starts[v], self.kinds[v], self.physics, self.vehicles, self.rng)
        else:
            respawn(v, self.kinds[v], self.physics, self.geometry, self.vehicles, self.rng)

    def fork(self) -> Crowd:
        """A crowd in this one's state (poses, lives, memories, random generator) that goes on
        apart from it; the world is shared."""
        twin = copy.copy(self)
        twin.kinds, twin.rng = self.kinds.copy(), self.rng.copy()
        twin.vehicles, twin.lives, twin.work = (
            type(record)(*(None if array is None else array.copy() for array in record))
            for record in (self.vehicles, self.lives, self.work))
        return twin

    def remove(self, vehicles) -> None:
        """The ``vehicles`` leave the arena; the others keep their order."""
        def without(record):
            return type(record)(*(np.delete(array, vehicles, axis=0) for array in record))
        self.kinds = np.delete(self.kinds, vehicles)
        self.vehicles, self.lives = without(self.vehicles), without(self.lives)
        self.work = self.work._replace(steering=np.delete(self.work.steering, vehicles))

    def run(self, seconds: float, genes: np.ndarray, learning: Learning | None = None,
            check_spins: bool = False) -> CrowdRun:
        """Drive for ``seconds`` of simulated time. ``genes`` (V, G, source layout) drive the
        network vehicles; a vehicle that ``learning`` learns drives with its current
        chromosome, and its learning hears of every life it ends and every life that reaches
        its cap. Learning vehicles, and with ``check_spins`` every network vehicle, lose their
        life when they spin in place."""
        count = len(self.kinds)
        lives = self.lives
        learns = [learning is not None and learning.learns(v) for v in range(count)]
        lives.spin_checked[:] = np.array(learns) | (check_spins & (self.kinds == NETWORK))
        unseen_from = lives.life.copy()  # steps of a life going on that an earlier run showed
        for v in np.flatnonzero(learns):
            genes[v] = learning.current(v)
        steps = round(seconds / self.world.scenario.vehicle.dt)
        collisions, spins = np.zeros(count, dtype=np.int64), np.zeros(count, dtype=np.int64)
        trace = np.empty((steps + 1, count, 3))
        t, drive_first, respawned = 0, False, False
        learners = np.flatnonzero(learns)
        cap = learning.life_cap if learning is not None and len(learners) else 0
        while True:
            # stop too when the oldest learning life reaches the cap
            last = steps if not cap else min(steps, t + cap - int(lives.life[learners].max()))
            t = advance(t, last, drive_first, respawned and self.blame_all_after_respawn,
                        self.kinds, genes, self.world.layer_sizes, self.physics, self.geometry,
                        self.vehicles, lives, self.rng, self.work, trace)
            ended = np.flatnonzero(lives.events != ALIVE)
            respawned = len(ended) > 0
            for v in ended:
                spun = bool(lives.events[v] == SPUN)
                spins[v] += spun
                collisions[v] += not spun
                if learns[v]:
                    genes[v] = learning.life_ended(v, int(lives.life[v]),
                                                   int(lives.life[v] - unseen_from[v]), spun)
                unseen_from[v] = 0
                self.respawn(v)
            for v in learners[lives.life[learners] >= cap] if cap else ():
                genes[v] = learning.life_capped(v, int(lives.life[v] - unseen_from[v]))
                unseen_from[v] = lives.life[v] = 0
            if t == steps:
                break
            drive_first = True
        for v in np.flatnonzero(learns):  # a life still going counts what it has shown
            learning.still_driving(v, int(lives.life[v] - unseen_from[v]),
                                  int(lives.life[v]))
        return CrowdRun(collisions, spins, steps * self.world.scenario.vehicle.dt, trace)
