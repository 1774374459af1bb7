"""Several learners at once in a live SUMO (paper §5.5 among SUMO traffic; docs/sumo.md).

K vehicles, each driven by a network, move through ``moveToXY`` among SUMO's own traffic,
which sees and reacts to them. Each learner senses the walls, SUMO's vehicles and the other
learners. The blame rule is the arena's and the closed loop's (:mod:`enn_traffic.sim.rules`,
:mod:`enn_traffic.sim.sumo.replay`):

- a learner whose body touches a wall, the body a SUMO vehicle had before the step, or the
  body another learner had before the step is responsible: its life ends and it re-enters at
  a free spot of the network (no wall, no vehicle within ``respawn_clearance``);
- a SUMO vehicle whose body touches a learner's body from before the step is responsible: the
  learner suffers the collision and the vehicle leaves that learner's world, as in the closed
  loop with one learner (it stays in SUMO and in the other learners' worlds);
- a learner that reaches an exit of the network has left it, and re-enters as after a
  collision; learners are held to §5.3's spin test.

Each SUMO step makes two compiled calls, whatever K: :func:`learner_events` (blame, exits, spins of
all learners) and :func:`drive` (all learners sense, decide and move). Each learner looks only
at the bodies in the cells around it (:mod:`enn_traffic.sim.buckets`), so a step costs
learners + vehicles, not learners × vehicles. Python respawns the learners whose lives ended,
calls their learning back (:class:`~enn_traffic.sim.crowd.Learning`), moves them in SUMO and
steps SUMO.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from numba import njit

from enn_traffic.core.errors import InputError
from enn_traffic.core.neural import steering as network_steering
from enn_traffic.sim.buckets import Buckets, buckets_for, fill, nearby
from enn_traffic.sim.crowd import ALIVE, CrowdRun, Learning
from enn_traffic.sim.rules import (
    NO_HIT,
    enter,
    hits_earlier_body,
    left_network,
    move_all,
    respawn_on_lanes,
    responsible,
    spun,
    vehicles_at,
    wall_arrays,
    work_for,
)
from enn_traffic.sim.sensors import (
    clear_seen,
    fill_channels,
    seen_for,
    sense_bodies,
    sense_walls_of,
)
from enn_traffic.sim.strategies import NETWORK
from enn_traffic.sim.sumo.replay import mark_absent, struck_by_traffic, visible_centres
from enn_traffic.sim.sumo.world import SumoWorld
from enn_traffic.sim.world import COLLIDED, LEFT_NETWORK, SPUN
from enn_traffic.sumo import command, recording, ssm, states
from enn_traffic.sumo.learners import add_learner, learner_id, move_learner, remove_learner
from enn_traffic.sumo.simulation import FAR, Simulation

RESPAWN_TRIES = 50  # free spots drawn before a learner re-enters beside SUMO's vehicles anyway


class Near(NamedTuple):
    """Work arrays: the bodies near one learner, gathered from their buckets (N rows)."""

    index: np.ndarray  # (N,) int64 their rows in the whole arrays
    ids: np.ndarray  # (N,) int64 SUMO's ids (slots)
    corners: np.ndarray  # (N, 4, 2)
    centres: np.ndarray  # (N, 2)
    gone: np.ndarray  # (N,) int64 the learner's ``gone`` (slots)
    absent: np.ndarray  # (N,) bool not in the learner's world before the step
    visible: np.ndarray  # (N, 2) the centres the learner sees (slots)
    before: np.ndarray  # (N, 2) the centres a step before, when the beams read motion


def near_for(rows: int) -> Near:
    """Room for ``rows`` bodies."""
    return Near(np.zeros(rows, dtype=np.int64), np.zeros(rows, dtype=np.int64),
                np.zeros((rows, 4, 2)), np.zeros((rows, 2)), np.zeros(rows, dtype=np.int64),
                np.zeros(rows, dtype=np.bool_), np.zeros((rows, 2)), np.zeros((rows, 2)))


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
        np.full((count, slots), -1, dtype=np.int64), (buckets_for(slots), buckets_for(slots)),
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
                  seen) -> None:
    """Learner ``k`` senses the walls, the SUMO vehicles in its world and the other
    learners into ``readings`` (the buckets filled by :func:`fill_now`): the steps of
    :func:`~enn_traffic.sim.sensors.sense`, with two groups of bodies."""
    pose, near, others = vehicles.pose, learners.near_slots, learners.near_learners
    x, y = pose[k, 0], pose[k, 1]
    beams, channels = geometry.beams, geometry.channels
    walls, cell_start, cell_walls, all_walls = wall_arrays(geometry)
    n = gather_slots(learners, k, x, y, slots, now)
    visible_centres(near.ids[:n], near.centres[:n], near.gone[:n], near.visible[:n])
    m, me = gather_learners(learners, k, x, y, vehicles.corners, vehicles.centres)
    if channels.shape[0] > 1:
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
    """Every learner senses (:func:`sense_learner`), its network (``genes[k]``) steers, and
    all move at once."""
    fill_now(physics, slots, now, vehicles, learners)
    for k in range(vehicles.pose.shape[0]):
        sense_learner(k, physics, geometry, slots, now, vehicles, learners, work.readings,
                      work.seen)
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


@dataclass
class SumoCrowdRun(CrowdRun):
    """A :class:`~enn_traffic.sim.crowd.CrowdRun` of learners among SUMO's traffic (the
    trace holds the learners' poses), with, per learner, the exits reached and the collisions
    SUMO vehicles caused; the span began at SUMO time ``begin``. The learners' SSM conflicts
    (TTC below its threshold, docs/sumo.md) are counted when the crowd closes (SUMO writes
    them then)."""

    exits: np.ndarray  # (K,)
    suffered: np.ndarray
    begin: float
    ttc_conflicts: int = 0

    @property
    def conflict_rate(self) -> float:
        """SSM conflicts (TTC below 1.5 s) per learner-hour."""
        return self.ttc_conflicts / (len(self.collisions) * self.seconds / 3600.0)


class SumoCrowd:
    """``scenario.traffic.learners`` learners in the live SUMO of the traffic situation
    ``seed``, after the scenario's warm-up; one SUMO for consecutive runs, as the arena's
    :class:`~enn_traffic.sim.crowd.Crowd` keeps its vehicles. Use it as a context manager:
    SUMO closes, and the runs' SSM conflicts are counted, on leaving it."""

    def __init__(self, world: SumoWorld, seed: int, starts: np.ndarray | None = None):
        """The learners enter at ``starts`` (K, 3: x, y, heading), or at free spots drawn
        from ``seed``."""
        self.world = world
        self.seed = seed
        self.count = world.scenario.traffic.learners
        self.ids = tuple(learner_id(k) for k in range(self.count))
        self._starts = starts
        self._simulation: Simulation | None = None
        self._runs: list[SumoCrowdRun] = []
        self.cost = {"learner_steps": 0, "wall_s": 0.0, "sumo_s": 0.0}  # of every run so far

    def __enter__(self) -> SumoCrowd:
        return self

    @property
    def simulation(self) -> Simulation | None:
        """The live SUMO, once started and until closed."""
        return self._simulation

    def __exit__(self, *exc) -> None:
        self.close()

    def start(self) -> None:
        """Start SUMO and put the learners in (:meth:`run` does it when first called)."""
        world, scenario = self.world, self.world.scenario
        vehicle = scenario.vehicle
        state = world.warm_state(self.seed) or states.warm_state(scenario, self.seed,
                                                               keep_rng=True)
        self._simulation = simulation = Simulation(
            scenario, self.seed, state, extra=ssm.ssm_options(self.ids), learners=self.ids)
        self.physics = world._learner_physics(simulation.largest_radius())
        self.slots = recording.slot_arrays(2, 64)
        self.before, self.now = 0, 1  # rows of the slot arrays; they swap every step
        self.lives = lives = _Lives(self.count, self.physics, world.geometry,
                                    world.layer_sizes, self.slots[0].shape[1], self.seed)
        self._read()
        for k in range(self.count):
            if self._starts is None:
                self.reenter(k)
            else:
                lives.place(k, self._starts[k], self.physics)
            add_learner(vehicle.length, vehicle.width, vehicle.speed, self.ids[k])
        self._move_learners()
        self.t = 0  # steps since the learners entered
        self._detected_at = -1  # the step last detected: once a step, whoever asks

    def reenter(self, k: int) -> None:
        """Learner ``k`` starts a new life at a free spot along the lanes."""
        world = self.world
        self.lives.enter(k, self.physics, world.geometry, world.lane_spots, self.slots,
                         self.now, world.scenario)

    def _move_learners(self) -> None:
        """Place every learner in SUMO for its next step (libsumo moves one vehicle a call)."""
        for vehicle, (x, y, heading), active in zip(self.ids, self.lives.pose.tolist(),
                                                    self.lives.learners.active, strict=True):
            if active:
                move_learner(x, y, heading, vehicle)

    def close(self) -> None:
        """End SUMO and count each run's SSM conflicts."""
        if self._simulation is None:
            return
        output = self._simulation.close(read=(command.SSM_FILE,))[command.SSM_FILE]
        self._simulation = None
        times = ssm.ttc_conflict_times(output)
        for run in self._runs:
            end = run.begin + run.seconds
            run.ttc_conflicts = int(((times >= run.begin) & (times < end)).sum())

    def _read(self) -> None:
        """SUMO's vehicles into the ``now`` row of the slot arrays (:func:`sumo.read_frame`),
        the learners' per-slot arrays growing with them; bodies larger than their type said
        widen the radius beyond which bodies cannot touch."""
        self.slots, radius = recording.read_frame(self._simulation, self.now, self.slots)
        if self.slots[0].shape[1] > self.lives.learners.gone.shape[1]:
            self.lives.grow(self.slots[0].shape[1])
        if radius > self.physics.radius:
            self.physics = self.physics._replace(radius=radius)

    def detect(self) -> bool:
        """The blame rule, exits and spins of the learners at this step (:func:`learner_events`):
        did a life end? ``lives.learners.events`` says whose. Once a step: a run that begins where
        the last one ended does not judge that step again (its collisions are counted, the
        lives that ended there re-entered)."""
        lives = self.lives
        if self._detected_at == self.t:
            lives.learners.events[:] = ALIVE
            return False
        self._detected_at = self.t
        return learner_events(self.t, lives.vehicles, lives.learners, self.physics,
                              self.world.geometry, self.slots, self.before, self.now)

    def advance(self) -> None:
        """The learners where they moved, SUMO one step on, its vehicles read."""
        self._move_learners()
        started = time.perf_counter()
        self._simulation.step()
        self.cost["sumo_s"] += time.perf_counter() - started
        self.before, self.now = self.now, self.before
        self._read()
        self.t += 1

    def leave(self, k: int) -> None:
        """Learner ``k`` leaves the network for good: out of SUMO, out of every world."""
        vehicles = self.lives.vehicles
        self.lives.learners.active[k] = False
        vehicles.pose[k], vehicles.centres[k], vehicles.previous_centres[k] = FAR, FAR, FAR
        vehicles.corners[k] = vehicles.previous[k] = FAR
        remove_learner(self.ids[k])

    def run(self, seconds: float, genes: np.ndarray, learning: Learning | None = None
            ) -> SumoCrowdRun:
        """Drive on for ``seconds`` of SUMO time; ``genes`` (K, G, source layout) drive the
        learners, and a learner that ``learning`` learns drives with its current chromosome
        and tells it of every life it ends and every life that reaches its cap."""
        if self._simulation is None:
            self.start()
        started = time.perf_counter()
        world, count, lives = self.world, self.count, self.lives
        learners = lives.learners  # its K-row arrays stay when SUMO's slots grow
        genes = np.array(genes, dtype=np.float64)
        learns = np.array([learning is not None and learning.learns(k) for k in range(count)])
        for k in np.flatnonzero(learns):
            genes[k] = learning.current(k)
        cap = learning.life_cap if learning is not None else 0
        steps = round(seconds / world.scenario.vehicle.dt)
        outcomes = {COLLIDED: np.zeros(count, np.int64), SPUN: np.zeros(count, np.int64),
                    LEFT_NETWORK: np.zeros(count, np.int64)}
        suffered = learners.suffered.copy()
        unseen_from = learners.life.copy()  # steps of a life going on that an earlier run showed
        begin = self._simulation.time()
        trace = np.empty((steps + 1, count, 3))
        for step in range(steps + 1):
            trace[step] = lives.pose
            if self.detect():
                for k in np.flatnonzero(learners.events != ALIVE):
                    outcome = int(learners.events[k])
                    outcomes[outcome][k] += 1
                    if learns[k]:
                        genes[k] = learning.life_ended(k, int(learners.life[k]),
                                                       int(learners.life[k] - unseen_from[k]),
                                                       outcome == SPUN)
                    unseen_from[k] = 0
                    self.reenter(k)
            for k in np.flatnonzero(learns & (learners.life >= cap)) if cap else ():
                genes[k] = learning.life_capped(k, int(learners.life[k] - unseen_from[k]))
                unseen_from[k] = learners.life[k] = 0
            if step == steps:
                break
            drive(genes, world.layer_sizes, self.physics, world.geometry, self.slots, self.now,
                  lives.vehicles, lives.learners, lives.work)
            self.advance()
        for k in np.flatnonzero(learns):  # a life still going counts what it has shown
            learning.still_driving(k, int(learners.life[k] - unseen_from[k]),
                                  int(learners.life[k]))
        run = SumoCrowdRun(outcomes[COLLIDED], outcomes[SPUN], steps * world.scenario.vehicle.dt,
                           trace, exits=outcomes[LEFT_NETWORK],
                           suffered=learners.suffered - suffered, begin=begin)
        self._runs.append(run)
        self.cost["learner_steps"] += count * steps
        self.cost["wall_s"] += time.perf_counter() - started
        return run


class _Lives:
    """The learners' arrays: poses and bodies (:class:`~enn_traffic.sim.rules.Vehicles`, as a
    world of K vehicles), their lives and worlds (:class:`Learners`), their work arrays and
    the generator of their re-entries."""

    def __init__(self, count: int, physics, geometry, layer_sizes: np.ndarray, slots: int,
                 seed: int):
        self.vehicles = vehicles = vehicles_at(count)
        vehicles.pose[:], vehicles.centres[:] = FAR, FAR  # not on the network yet
        vehicles.corners[:] = vehicles.previous[:] = 0.0
        vehicles.previous_centres[:] = FAR
        vehicles.fresh[:] = True
        self.learners = learners_for(count, physics.spin_window, slots)
        self.work = work_for(geometry, layer_sizes, count)
        self.rng = np.full(1, np.uint64(seed), dtype=np.uint64)

    @property
    def pose(self) -> np.ndarray:
        """(K, 3) every learner's pose."""
        return self.vehicles.pose

    def grow(self, slots: int) -> None:
        """Room for ``slots`` SUMO slots (the new ones in every learner's world)."""
        old = self.learners.gone
        gone = np.full((len(old), slots), -1, dtype=np.int64)
        gone[:, : old.shape[1]] = old
        self.learners = self.learners._replace(
            gone=gone, slot_buckets=(buckets_for(slots), buckets_for(slots)),
            near_slots=near_for(slots))

    def place(self, k: int, pose: np.ndarray, physics) -> None:
        """Learner ``k`` starts a life at ``pose``."""
        enter(k, *pose, NETWORK, physics, self.vehicles, self.rng)
        self.learners.life[k] = 0
        self.learners.gone[k] = -1

    def enter(self, k: int, physics, geometry, spots: np.ndarray, slots: tuple, row: int,
              scenario) -> None:
        """Learner ``k`` starts a life at a free spot: one of ``spots`` along the lanes
        (facing their traffic), touching no wall, ``respawn_clearance`` from every learner
        and, if one is found within :data:`RESPAWN_TRIES` draws, from every SUMO vehicle."""
        ids, _, centres = slots
        present = ids[row] >= 0
        for _ in range(RESPAWN_TRIES):
            if not respawn_on_lanes(k, NETWORK, spots, physics, geometry, self.vehicles,
                                    self.rng):
                raise InputError("no free spot for a learner along the lanes in 200 draws "
                                 "(learners packed closer than traffic.respawn_clearance?)",
                                 scenario.source, "track.net")
            gaps = np.hypot(*(centres[row][present] - self.vehicles.centres[k]).T)
            if not np.any(gaps < physics.clearance):
                break
        self.learners.life[k] = 0
        self.learners.gone[k] = -1
