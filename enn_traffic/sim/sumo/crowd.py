"""Several learners at once in a live SUMO (paper §5.5 among SUMO traffic; docs/sumo.md).

K vehicles, each driven by a network, move through ``moveToXY`` among SUMO's own traffic,
which sees and reacts to them. Each learner senses the walls, SUMO's vehicles and the other
learners; the blame rule is the arena's and the closed loop's
(:mod:`enn_traffic.sim.sumo.crowd_rules` says it in full).

Each SUMO step makes two compiled calls, whatever K: :func:`~.crowd_rules.learner_events`
(blame, exits, spins of all learners) and :func:`~.crowd_rules.drive` (all learners sense,
count their 2-D conflicts, decide and move). Python respawns the learners whose lives ended,
calls their learning back (:class:`~enn_traffic.sim.crowd.Learning`), moves them in SUMO and
steps SUMO.
"""
from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from enn_traffic.core.errors import InputError
from enn_traffic.sim.buckets import buckets_for
from enn_traffic.sim.crowd import ALIVE, CrowdRun, Learning
from enn_traffic.sim.rules import (
    enter,
    vehicles_at,
    work_for,
)
from enn_traffic.sim.strategies import NETWORK
from enn_traffic.sim.sumo.crowd_rules import (
    drive,
    learner_events,
    learners_for,
    near_for,
    reenter,
)
from enn_traffic.sim.sumo.world import SumoWorld
from enn_traffic.sim.world import COLLIDED, LEFT_NETWORK, SPUN
from enn_traffic.sumo import command, recording, ssm, states
from enn_traffic.sumo.learners import add_learner, learner_id, move_learner, remove_learner
from enn_traffic.sumo.simulation import FAR, Simulation

RESPAWN_TRIES = 50  # free spots drawn before a learner re-enters beside SUMO's vehicles anyway
# Random draws fill lanes with learners at respawn_clearance apart only so far (random
# sequential adsorption jams near 3/4 of the lanes' room): refused above this share of it
PACKING = 0.5


def check_room(world: SumoWorld, key: str = "traffic.learners") -> None:
    """Refuse, in seconds, more learners than the world's lanes can take in at
    ``traffic.respawn_clearance`` apart; ``key``: where the count came from (a key of the
    scenario file, or an option or argument that set it)."""
    scenario, spots = world.scenario, world.lane_spots
    spacing = max(scenario.traffic.respawn_clearance, scenario.vehicle.length)
    room = int(len(spots) * 5.0 / spacing * PACKING)  # lane_spots: a spot every 5 m
    if scenario.traffic.learners > room:
        raise InputError(f"{scenario.traffic.learners} learners do not fit: the lanes learners "
                         f"enter on ({len(spots) * 5.0 / 1000:.1f} km) take about {room} at "
                         f"traffic.respawn_clearance = {scenario.traffic.respawn_clearance:g} m "
                         "apart", scenario.source if key.startswith("traffic.") else None, key)


@dataclass
class SumoCrowdRun(CrowdRun):
    """A :class:`~enn_traffic.sim.crowd.CrowdRun` of learners among SUMO's traffic (the
    trace holds the learners' poses), with, per learner, the exits reached and the collisions
    SUMO vehicles caused; the span began at SUMO time ``begin``. The learners' SSM conflicts
    (TTC below its threshold, docs/sumo.md) are counted when the crowd closes (SUMO writes
    them then), and their 2-D conflicts (the 2-D time to collision over the footprints coming
    below the same threshold, :func:`~.crowd_rules.count_conflict`) as they drive."""

    exits: np.ndarray  # (K,)
    suffered: np.ndarray
    begin: float
    conflicts_2d: int = 0
    ttc_conflicts: int = 0

    @property
    def conflict_rate(self) -> float:
        """SSM conflicts (TTC below 1.5 s) per learner-hour."""
        return self.ttc_conflicts / (len(self.collisions) * self.seconds / 3600.0)

    @property
    def conflict_rate_2d(self) -> float:
        """2-D conflicts (2-D TTC coming below 1.5 s) per learner-hour."""
        return self.conflicts_2d / (len(self.collisions) * self.seconds / 3600.0)


class SumoCrowd:
    """``scenario.traffic.learners`` learners in the live SUMO of the traffic situation
    ``seed``, after the scenario's warm-up; one SUMO for consecutive runs, as the arena's
    :class:`~enn_traffic.sim.crowd.Crowd` keeps its vehicles. Use it as a context manager:
    SUMO closes, and the runs' SSM conflicts are counted, on leaving it."""

    def __init__(self, world: SumoWorld, seed: int, starts: np.ndarray | None = None,
                 ssm_devices: bool = True):
        """The learners enter at ``starts`` (K, 3: x, y, heading), or at free spots drawn
        from ``seed``; they carry SSM devices unless not ``ssm_devices`` (then no SSM
        conflict is counted)."""
        self.world = world
        self.ssm_devices = ssm_devices
        self.seed = seed
        self.count = world.scenario.traffic.learners
        self.ids = tuple(learner_id(k) for k in range(self.count))
        self._starts = starts
        self._simulation: Simulation | None = None
        self._runs: list[SumoCrowdRun] = []
        # of every run so far: wall and this process's CPU seconds, in all and in SUMO's step
        # (CPU time is what an arm costs when arms share the cores side by side)
        self.cost = {"learner_steps": 0, "wall_s": 0.0, "sumo_s": 0.0, "cpu_s": 0.0,
                     "sumo_cpu_s": 0.0}

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
        state = world.warm_state(self.seed) or states.warm_state(scenario, self.seed,
                                                               keep_rng=True)
        devices = ssm.ssm_options() if self.ssm_devices else ()
        self._simulation = simulation = Simulation(scenario, self.seed, state, extra=devices,
                                                   learners=self.ids)
        try:
            self._enter(simulation)
        except BaseException:  # SUMO ends with the failed start, as with a failed step
            self._simulation = None
            simulation.close()
            raise

    def _enter(self, simulation: Simulation) -> None:
        """The learners into the started ``simulation``, at their starts or free spots."""
        vehicle = self.world.scenario.vehicle
        world = self.world
        self.physics = world._learner_physics(simulation.largest_radius())
        self.slots = recording.slot_arrays(2, 64)
        self.before, self.now = 0, 1  # rows of the slot arrays; they swap every step
        self.lives = lives = _Lives(self.count, self.physics, world.geometry,
                                    world.layer_sizes, self.slots[0].shape[1], self.seed)
        self._read()
        if self._starts is None:
            self.reenter(np.arange(self.count))
        for k in range(self.count):
            if self._starts is not None:
                lives.place(k, self._starts[k], self.physics)
            add_learner(vehicle.length, vehicle.width, vehicle.speed, self.ids[k],
                        simulation.has_ssm_options)
        self._move_learners()
        self.t = 0  # steps since the learners entered
        self._detected_at = -1  # the step last detected: once a step, whoever asks

    def reenter(self, learners) -> None:
        """The ``learners`` (indices, in order) start new lives at free spots along the
        lanes."""
        world = self.world
        self.lives.enter(np.asarray(learners, dtype=np.int64).reshape(-1), self.physics,
                         world.geometry, world.lane_spots, self.slots, self.now,
                         world.scenario)

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
        """The blame rule, exits and spins of the learners at this step
        (:func:`~.crowd_rules.learner_events`): did a life end? ``lives.learners.events`` says
        whose. Once a step: a run that begins where the last one ended does not judge that step
        again (its collisions are counted, the lives that ended there re-entered)."""
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
        started, cpu = time.perf_counter(), time.process_time()
        self._simulation.step()
        self.cost["sumo_s"] += time.perf_counter() - started
        self.cost["sumo_cpu_s"] += time.process_time() - cpu
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
        started, cpu = time.perf_counter(), time.process_time()
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
        suffered, conflicts = learners.suffered.copy(), int(learners.conflicts.sum())
        unseen_from = learners.life.copy()  # steps of a life going on that an earlier run showed
        begin = self._simulation.time()
        trace = np.empty((steps + 1, count, 3))
        for step in range(steps + 1):
            trace[step] = lives.pose
            if self.detect():
                ended = np.flatnonzero(learners.events != ALIVE)
                for k in ended:
                    outcome = int(learners.events[k])
                    outcomes[outcome][k] += 1
                    if learns[k]:
                        genes[k] = learning.life_ended(k, int(learners.life[k]),
                                                       int(learners.life[k] - unseen_from[k]),
                                                       outcome == SPUN)
                    unseen_from[k] = 0
                self.reenter(ended)  # in order, as each depends on those before
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
                           suffered=learners.suffered - suffered, begin=begin,
                           conflicts_2d=int(learners.conflicts.sum()) - conflicts)
        self._runs.append(run)
        self.cost["learner_steps"] += count * steps
        self.cost["wall_s"] += time.perf_counter() - started
        self.cost["cpu_s"] += time.process_time() - cpu
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
        self.clear_of_walls: np.ndarray | None = None  # per lane spot (rules.respawn_on_lanes)

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
        self.learners.closing[k] = False

    def enter(self, entering: np.ndarray, physics, geometry, spots: np.ndarray, slots: tuple,
              row: int, scenario) -> None:
        """The learners ``entering`` (in order) start lives at free spots: each at one of
        ``spots`` along the lanes (facing their traffic), touching no wall,
        ``respawn_clearance`` from every learner and, if one is found within
        :data:`RESPAWN_TRIES` draws, from every SUMO vehicle (:func:`~.crowd_rules.reenter`,
        one compiled call for all)."""
        if self.clear_of_walls is None:  # the world's spots, known at the first entry
            self.clear_of_walls = np.full(len(spots), -1, dtype=np.int8)  # none known yet
        ids, _, centres = slots
        if reenter(entering, NETWORK, spots, self.clear_of_walls, physics, geometry,
                   self.vehicles, self.rng, centres[row], ids[row],
                   RESPAWN_TRIES) < len(entering):
            raise InputError("no free spot for a learner along the lanes in 200 draws "
                             "(learners packed closer than traffic.respawn_clearance?)",
                             scenario.source, "track.net")
        self.learners.life[entering] = 0
        self.learners.gone[entering] = -1
        self.learners.closing[entering] = False
