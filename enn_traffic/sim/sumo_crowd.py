"""Several learners at once in a live SUMO (paper §5.5 among SUMO traffic; docs/sumo.md).

K vehicles, each driven by a network, move through ``moveToXY`` among SUMO's own traffic,
which sees and reacts to them. Each learner senses the walls, SUMO's vehicles and the other
learners. The blame rule is the arena's and the closed loop's (:mod:`enn_traffic.sim.rules`,
:mod:`enn_traffic.sim.replay`):

- a learner whose body touches a wall, the body a SUMO vehicle had before the step, or the
  body another learner had before the step is responsible: its life ends and it re-enters at
  a free spot of the network (no wall, no vehicle within ``respawn_clearance``);
- a SUMO vehicle whose body touches a learner's body from before the step is responsible: the
  learner suffers the collision and the vehicle leaves that learner's world, as in the closed
  loop with one learner (it stays in SUMO and in the other learners' worlds);
- a learner that reaches an exit of the network has left it, and re-enters as after a
  collision; learners are held to §5.3's spin test.

Each SUMO step makes two compiled calls, whatever K: :func:`learner_events` (blame, exits, spins of
all learners) and :func:`drive` (all learners sense, decide and move). Python respawns the
learners whose lives ended, calls their learning back (:class:`~enn_traffic.sim.crowd.Learning`),
moves them in SUMO and steps SUMO.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit

from enn_traffic.errors import InputError
from enn_traffic.neural import network_buffers
from enn_traffic.neural import steering as network_steering
from enn_traffic.sim.crowd import ALIVE, CrowdRun, Learning
from enn_traffic.sim.replay import mark_absent, struck_by_traffic, visible_centres
from enn_traffic.sim.rules import (
    NO_HIT,
    hits_earlier_body,
    left_network,
    move_all,
    place,
    respawn_on_lanes,
    responsible,
    sense,
    sense_bodies,
    spun,
)
from enn_traffic.sim.strategies import NETWORK
from enn_traffic.sim.sumo_world import SumoWorld
from enn_traffic.sim.world import COLLIDED, LEFT_NETWORK, SPUN
from enn_traffic.traffic import sumo
from enn_traffic.traffic.sumo import FAR

RESPAWN_TRIES = 50  # free spots drawn before a learner re-enters beside SUMO's vehicles anyway


@njit(cache=True)
def learner_events(t, pose, body, centre, body_before, centre_before, fresh, life, recent,
                   spin_checked, active, physics, geometry, ids, corners, centres, before, now,
                   gone, absent, suffered, events) -> bool:
    """Fill ``events`` (K,): ``COLLIDED`` for an ``active`` learner responsible for a
    collision, ``LEFT_NETWORK`` at an exit, ``SPUN`` for a spin, else ``ALIVE``; count the
    collisions SUMO vehicles cause (``suffered``) and take those vehicles out of the learner's
    world (``gone[k]``). Did any life end?"""
    walls, cell_start, cell_walls = geometry.walls, geometry.cell_start, geometry.cell_walls
    all_walls, exits = geometry.all_walls, geometry.exits
    ids_before, corners_before, centres_before = ids[before], corners[before], centres[before]
    ids_now, corners_now, centres_now = ids[now], corners[now], centres[now]
    near = 4.0 * physics.radius * physics.radius
    ended = False
    for k in range(pose.shape[0]):
        events[k] = ALIVE
        if not active[k]:
            continue
        if left_network(body[k], exits):
            events[k] = LEFT_NETWORK
            ended = True
            continue
        mark_absent(t, ids_before, gone[k], absent)
        if (responsible(k, pose, body, centre, corners_before, centres_before, absent, -1,
                        physics, walls, cell_start, cell_walls, all_walls) != NO_HIT
                or hits_earlier_body(k, body, centre, body_before, centre_before, fresh, k,
                                     near) != NO_HIT):
            events[k] = COLLIDED
            ended = True
            continue
        if t > 0 and not fresh[k]:
            suffered[k] += struck_by_traffic(k, body_before, centre_before, ids_now, corners_now,
                                             centres_now, gone[k], near)
        if spin_checked[k] and spun(recent[k], life[k], pose[k, 0], pose[k, 1],
                                    physics.spin_variance):
            events[k] = SPUN
            ended = True
    return ended


@njit(cache=True, inline="always")
def sense_learner(k, physics, geometry, ids_now, corners_now, centres_now, pose, body, centre,
                  gone, visible, readings) -> None:
    """Learner ``k`` senses the walls, the SUMO vehicles in its world and the other
    learners into ``readings``."""
    beams, walls, cell_start = geometry.beams, geometry.walls, geometry.cell_start
    cell_walls, all_walls = geometry.cell_walls, geometry.all_walls
    visible_centres(ids_now, centres_now, gone[k], visible)
    sense(k, pose, physics, beams, walls, cell_start, cell_walls, all_walls,
          True, corners_now, visible, -1, readings)
    sense_bodies(k, pose[k, 0], pose[k, 1], math.cos(pose[k, 2]), math.sin(pose[k, 2]),
                 beams, body, centre,
                 physics.radius, readings)


@njit(cache=True, inline="always")
def move(steering, physics, pose, body, centre, body_before, centre_before, fresh, life
         ) -> None:
    """All learners move at once, each by its ``steering``."""
    move_all(steering, physics, pose, body, centre, body_before, centre_before, fresh)
    life += 1


@njit(cache=True)
def drive(genes, layer_sizes, physics, geometry, ids, corners, centres, now, pose, body,
          centre, body_before, centre_before, fresh, life, gone, visible, readings, activation,
          scratch, steering) -> None:
    """Every learner senses (:func:`sense_learner`), its network (``genes[k]``) steers, and
    all move at once."""
    ids_now, corners_now, centres_now = ids[now], corners[now], centres[now]
    for k in range(pose.shape[0]):
        sense_learner(k, physics, geometry, ids_now, corners_now, centres_now, pose, body,
                      centre, gone, visible, readings)
        steering[k] = network_steering(genes[k], layer_sizes, readings, activation, scratch,
                                       physics.gain)
    move(steering, physics, pose, body, centre, body_before, centre_before, fresh, life)


@njit(cache=True)
def observe(active, physics, geometry, ids, corners, centres, now, pose, body, centre, gone,
            visible, out) -> None:
    """Every ``active`` learner ``k`` senses into ``out[k]`` (for a caller that steers them
    from outside: the PettingZoo SUMO crowd, :mod:`enn_traffic.envs.sumo`)."""
    for k in range(pose.shape[0]):
        if active[k]:
            sense_learner(k, physics, geometry, ids[now], corners[now], centres[now], pose,
                          body, centre, gone, visible, out[k])


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
        self.ids = tuple(sumo.learner_id(k) for k in range(self.count))
        self._starts = starts
        self._simulation: sumo.Simulation | None = None
        self._runs: list[SumoCrowdRun] = []

    def __enter__(self) -> SumoCrowd:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def start(self) -> None:
        """Start SUMO and put the learners in (:meth:`run` does it when first called)."""
        world, scenario = self.world, self.world.scenario
        vehicle = scenario.vehicle
        state = world.warm_state(self.seed) or sumo.warm_state(scenario, self.seed,
                                                               keep_rng=True)
        self._simulation = simulation = sumo.Simulation(
            scenario, self.seed, state, extra=sumo.ssm_options(self.ids), learners=self.ids)
        self.physics = world._learner_physics(simulation.largest_radius())
        self.slots = sumo.slot_arrays(2, 64)
        self.before, self.now = 0, 1  # rows of the slot arrays; they swap every step
        self.lives = lives = _Lives(self.count, self.physics, len(world.geometry.beams),
                                    world.layer_sizes, self.slots[0].shape[1], self.seed)
        self._read()
        for k in range(self.count):
            if self._starts is None:
                self.reenter(k)
            else:
                lives.place(k, self._starts[k], self.physics)
            sumo.add_learner(vehicle.length, vehicle.width, vehicle.speed, self.ids[k])
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
                                                    self.lives.active, strict=True):
            if active:
                sumo.move_learner(x, y, heading, vehicle)

    def close(self) -> None:
        """End SUMO and count each run's SSM conflicts."""
        if self._simulation is None:
            return
        output = self._simulation.close(read=(sumo.SSM_FILE,))[sumo.SSM_FILE]
        self._simulation = None
        times = sumo.ttc_conflict_times(output)
        for run in self._runs:
            end = run.begin + run.seconds
            run.ttc_conflicts = int(((times >= run.begin) & (times < end)).sum())

    def _read(self) -> None:
        """SUMO's vehicles into the ``now`` row of the slot arrays (:func:`sumo.read_frame`),
        the learners' per-slot arrays growing with them; bodies larger than their type said
        widen the radius beyond which bodies cannot touch."""
        self.slots, radius = sumo.read_frame(self._simulation, self.now, self.slots)
        if self.slots[0].shape[1] > self.lives.gone.shape[1]:
            self.lives.grow(self.slots[0].shape[1])
        if radius > self.physics.radius:
            self.physics = self.physics._replace(radius=radius)

    def detect(self) -> bool:
        """The blame rule, exits and spins of the learners at this step (:func:`learner_events`):
        did a life end? ``lives.events`` says whose. Once a step: a run that begins where
        the last one ended does not judge that step again (its collisions are counted, the
        lives that ended there re-entered)."""
        lives, ids, corners, centres = self.lives, *self.slots
        if self._detected_at == self.t:
            lives.events[:] = ALIVE
            return False
        self._detected_at = self.t
        return learner_events(self.t, lives.pose, lives.body, lives.centre, lives.body_before,
                              lives.centre_before, lives.fresh, lives.life, lives.recent,
                              lives.spin_checked, lives.active, self.physics,
                              self.world.geometry, ids, corners, centres, self.before, self.now,
                              lives.gone, lives.absent, lives.suffered, lives.events)

    def advance(self) -> None:
        """The learners where they moved, SUMO one step on, its vehicles read."""
        self._move_learners()
        self._simulation.step()
        self.before, self.now = self.now, self.before
        self._read()
        self.t += 1

    def leave(self, k: int) -> None:
        """Learner ``k`` leaves the network for good: out of SUMO, out of every world."""
        lives = self.lives
        lives.active[k] = False
        lives.pose[k], lives.centre[k], lives.centre_before[k] = FAR, FAR, FAR
        lives.body[k] = lives.body_before[k] = FAR
        sumo.remove_learner(self.ids[k])

    def run(self, seconds: float, genes: np.ndarray, learning: Learning | None = None
            ) -> SumoCrowdRun:
        """Drive on for ``seconds`` of SUMO time; ``genes`` (K, G, source layout) drive the
        learners, and a learner that ``learning`` learns drives with its current chromosome
        and tells it of every life it ends and every life that reaches its cap."""
        if self._simulation is None:
            self.start()
        world, count, lives = self.world, self.count, self.lives
        genes = np.array(genes, dtype=np.float64)
        learns = np.array([learning is not None and learning.learns(k) for k in range(count)])
        for k in np.flatnonzero(learns):
            genes[k] = learning.current(k)
        cap = learning.life_cap if learning is not None else 0
        steps = round(seconds / world.scenario.vehicle.dt)
        outcomes = {COLLIDED: np.zeros(count, np.int64), SPUN: np.zeros(count, np.int64),
                    LEFT_NETWORK: np.zeros(count, np.int64)}
        suffered = lives.suffered.copy()
        unseen_from = lives.life.copy()  # steps of a life going on that an earlier run showed
        begin = self._simulation.time()
        trace = np.empty((steps + 1, count, 3))
        for step in range(steps + 1):
            trace[step] = lives.pose
            ids, corners, centres = self.slots
            if self.detect():
                for k in np.flatnonzero(lives.events != ALIVE):
                    outcome = int(lives.events[k])
                    outcomes[outcome][k] += 1
                    if learns[k]:
                        genes[k] = learning.life_ended(k, int(lives.life[k]),
                                                       int(lives.life[k] - unseen_from[k]),
                                                       outcome == SPUN)
                    unseen_from[k] = 0
                    self.reenter(k)
            for k in np.flatnonzero(learns & (lives.life >= cap)) if cap else ():
                genes[k] = learning.life_capped(k, int(lives.life[k] - unseen_from[k]))
                unseen_from[k] = lives.life[k] = 0
            if step == steps:
                break
            drive(genes, world.layer_sizes, self.physics, world.geometry, ids, corners,
                  centres, self.now, lives.pose, lives.body, lives.centre, lives.body_before,
                  lives.centre_before, lives.fresh, lives.life, lives.gone, lives.visible,
                  lives.readings, lives.activation, lives.scratch, lives.steering)
            self.advance()
        for k in np.flatnonzero(learns):  # a life still going counts what it has shown
            learning.still_driving(k, int(lives.life[k] - unseen_from[k]))
        run = SumoCrowdRun(outcomes[COLLIDED], outcomes[SPUN], steps * world.scenario.vehicle.dt,
                           trace, exits=outcomes[LEFT_NETWORK], suffered=lives.suffered - suffered,
                           begin=begin)
        self._runs.append(run)
        return run


class _Lives:
    """The learners' arrays: poses and bodies (as a world of K vehicles), each one's life so
    far, and per SUMO slot the vehicles that left its world."""

    def __init__(self, count: int, physics, beams: int, layer_sizes: np.ndarray, slots: int,
                 seed: int):
        self.pose = np.full((count, 3), FAR)  # not on the network yet
        self.body = np.zeros((count, 4, 2))
        self.centre = np.full((count, 2), FAR)
        self.body_before, self.centre_before = self.body.copy(), self.centre.copy()
        self.fresh = np.ones(count, dtype=np.bool_)
        self.life = np.zeros(count, dtype=np.int64)
        self.recent = np.zeros((count, physics.spin_window, 2))
        self.spin_checked = np.ones(count, dtype=np.bool_)
        self.active = np.ones(count, dtype=np.bool_)  # False: left the network for good
        self.gone = np.full((count, slots), -1, dtype=np.int64)
        self.absent = np.empty(slots, dtype=np.bool_)
        self.visible = np.empty((slots, 2))
        self.suffered = np.zeros(count, dtype=np.int64)
        self.events = np.full(count, ALIVE, dtype=np.int64)
        self.memory = np.zeros((count, 2))
        self.readings = np.empty(beams)
        self.activation, self.scratch = network_buffers(layer_sizes)
        self.steering = np.zeros(count)
        self.rng = np.full(1, np.uint64(seed), dtype=np.uint64)

    def grow(self, slots: int) -> None:
        """Room for ``slots`` SUMO slots (the new ones in every learner's world)."""
        gone = np.full((len(self.gone), slots), -1, dtype=np.int64)
        gone[:, : self.gone.shape[1]] = self.gone
        self.gone = gone
        self.absent = np.empty(slots, dtype=np.bool_)
        self.visible = np.empty((slots, 2))

    def place(self, k: int, pose: np.ndarray, physics) -> None:
        """Learner ``k`` starts a life at ``pose``."""
        place(k, *pose, physics, self.pose, self.body, self.centre)
        self.body_before[k], self.centre_before[k] = self.body[k], self.centre[k]
        self.fresh[k] = True
        self.life[k] = 0
        self.gone[k] = -1

    def enter(self, k: int, physics, geometry, spots: np.ndarray, slots: tuple, row: int,
              scenario) -> None:
        """Learner ``k`` starts a life at a free spot: one of ``spots`` along the lanes
        (facing their traffic), touching no wall, ``respawn_clearance`` from every learner
        and, if one is found within :data:`RESPAWN_TRIES` draws, from every SUMO vehicle."""
        walls, cell_start, cell_walls = geometry.walls, geometry.cell_start, geometry.cell_walls
        all_walls = geometry.all_walls
        ids, _, centres = slots
        present = ids[row] >= 0
        for _ in range(RESPAWN_TRIES):
            if not respawn_on_lanes(k, NETWORK, spots, physics, walls, cell_start,
                                    cell_walls, all_walls, self.pose, self.body, self.centre,
                                    self.body_before, self.centre_before, self.fresh,
                                    self.memory, self.rng):
                raise InputError("no free spot for a learner along the lanes in 200 draws "
                                 "(learners packed closer than traffic.respawn_clearance?)",
                                 scenario.source, "track.net")
            gaps = np.hypot(*(centres[row][present] - self.centre[k]).T)
            if not np.any(gaps < physics.clearance):
                break
        self.life[k] = 0
        self.gone[k] = -1
