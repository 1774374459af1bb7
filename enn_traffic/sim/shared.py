"""One arena where every vehicle drives by its own controller, and may learn while it drives
(paper §5.5; docs/design.md, "The authors' code" 6).

Unlike :mod:`enn_traffic.sim.world`, which runs one learner per world and P worlds at once,
this is one world of V vehicles run for a stretch of simulated time. Each step:

1. :func:`detect` — collisions by the blame rule (a vehicle is responsible if its body touches
   a wall or another vehicle's body from before the step), and the spin test for learning
   vehicles (and for every network vehicle when asked: evolved drivers are held to §5.3's
   rule that rotating in place ends a life);
2. the caller ends those lives: a learning vehicle records the fitness of its chromosome and
   takes the next one (its own GA when its population is used up, :class:`VehicleGA`); every
   vehicle whose life ended respawns at a free spot (the arena's respawn rule);
3. :func:`drive` — every vehicle senses walls and the other bodies, decides and moves.

Collision rate (the metric of Tables 3–4): responsible collisions per second of simulated time,
per vehicle — all responsible collisions, each counted once for each vehicle responsible,
divided by the number of vehicles and the simulated time.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numba import njit

from enn_traffic.evolution import ga
from enn_traffic.sim.kinematics import bicycle_step
from enn_traffic.sim.sensors import nearby_walls, sense_walls
from enn_traffic.sim.world import (
    COLLIDED,
    NO_HIT,
    SPUN,
    World,
    _place,
    _respawn,
    _responsible,
    _sense_bodies,
    _small_spread,
    network_steering,
)
from enn_traffic.traffic.kinematic import (
    NONE,
    P_CLEARANCE,
    RANDOM_NETWORK,
    reset_memory,
    scripted_steering,
    senses_vehicles,
)

ALIVE = -1


@njit(cache=True)
def detect(pose, corners, centres, previous, previous_centres, fresh, spin_checked, life, recent,
           walls, lookup, radius, spin_variance, events) -> None:
    """Fill ``events`` (V,): ``COLLIDED`` for a responsible collision, ``SPUN`` for a
    ``spin_checked`` vehicle spinning in place, else ``ALIVE``; record this step's positions for
    the spin test."""
    near = 4.0 * radius * radius
    window = recent.shape[1]
    for v in range(pose.shape[0]):
        events[v] = ALIVE
        if _responsible(v, pose, corners, centres, previous, previous_centres, fresh, walls,
                        lookup, near) != NO_HIT:
            events[v] = COLLIDED
        elif spin_checked[v]:
            slot = life[v] % window
            recent[v, slot, 0], recent[v, slot, 1] = pose[v, 0], pose[v, 1]
            if life[v] + 1 >= window and _small_spread(recent[v], spin_variance):
                events[v] = SPUN


@njit(cache=True)
def respawn(v, kind, pose, corners, centres, previous, previous_centres, fresh, memory, life,
            length, width, walls, lookup, bounds, params, rng) -> None:
    """Put vehicle ``v`` at a random free spot with a fresh life."""
    _respawn(v, pose, corners, centres, length, width, walls, lookup, bounds, params[P_CLEARANCE],
             rng)
    previous[v] = corners[v]
    previous_centres[v] = centres[v]
    fresh[v] = True
    life[v] = 0
    reset_memory(kind, params, rng, memory[v])


@njit(cache=True)
def drive(pose, corners, centres, previous, previous_centres, fresh, kinds, genes, layer_sizes,
          gain, length, width, wheelbase, distance, beam_cos, beam_sin, max_range, walls, lookup,
          params, memory, rng, radius, life) -> None:
    """Every vehicle senses, decides (its own genes, or its scripted strategy) and moves."""
    count = pose.shape[0]
    readings = np.empty(beam_cos.shape[0])
    width_max = max(layer_sizes.max(), 2)
    activation = np.empty(width_max)
    scratch = np.empty(width_max)
    steering = np.zeros(count)
    for v in range(count):
        kind = kinds[v]
        candidates = nearby_walls(pose[v, 0], pose[v, 1], lookup)
        sense_walls(pose[v, 0], pose[v, 1], pose[v, 2], beam_cos, beam_sin, max_range, walls,
                    candidates, readings)
        if senses_vehicles(kind, params):
            _sense_bodies(v, pose[v, 0], pose[v, 1], pose[v, 2], beam_cos, beam_sin, corners,
                          centres, radius, readings)
        if kind == RANDOM_NETWORK:
            steering[v] = network_steering(genes[v], layer_sizes, readings, activation, scratch,
                                           gain)
        elif kind != NONE:
            steering[v] = scripted_steering(kind, readings, beam_cos, beam_sin, max_range,
                                            params, memory[v], rng)
    previous[:] = corners
    previous_centres[:] = centres
    fresh[:] = False
    for v in range(count):
        x, y, heading = bicycle_step(pose[v, 0], pose[v, 1], pose[v, 2], steering[v], distance,
                                     wheelbase)
        _place(v, x, y, heading, length, width, pose, corners, centres)
        life[v] += 1


@dataclass
class VehicleGA:
    """One vehicle's own population, evaluated a chromosome per life (reference §7.1)."""

    population: np.ndarray  # (P, G), the world's gene layout
    rng: np.random.Generator
    fitness: np.ndarray = field(init=False)
    index: int = 0
    generation: int = 0

    def __post_init__(self):
        self.fitness = np.zeros(len(self.population))

    @property
    def current(self) -> np.ndarray:
        return self.population[self.index]

    def record(self, fitness: float) -> None:
        """The current chromosome's life ended with ``fitness``."""
        self.fitness[self.index] = fitness
        self.index += 1

    @property
    def exhausted(self) -> bool:
        return self.index >= len(self.population)

    def advance(self, params: ga.GAParams, global_elites: np.ndarray | None = None) -> None:
        """The next generation; ``global_elites`` (the best chromosomes of all vehicles,
        reference §7.4) replace its own elites when given."""
        population = ga.next_generation(self.rng, self.population, self.fitness, params)
        if global_elites is not None and len(global_elites):
            population[: len(global_elites)] = global_elites
        self.population, self.index, self.generation = population, 0, self.generation + 1
        self.fitness = np.zeros(len(population))


@dataclass
class Evidence:
    """What was seen of each chromosome, pooled over every vehicle and run that recorded it
    (the learning vehicles share what they learn, reference §7.4): steps driven with it and
    lives it lost (a responsible collision or a spin)."""

    chromosomes: dict[bytes, np.ndarray] = field(default_factory=dict)
    steps: dict[bytes, int] = field(default_factory=dict)
    losses: dict[bytes, int] = field(default_factory=dict)

    def record(self, genes: np.ndarray, steps: int, losses: int) -> None:
        """``genes`` drove ``steps`` more steps and lost ``losses`` more lives."""
        key = genes.tobytes()
        if key not in self.chromosomes:
            self.chromosomes[key] = genes.copy()
        self.steps[key] = self.steps.get(key, 0) + steps
        self.losses[key] = self.losses.get(key, 0) + losses

    def loss_rate(self, key: bytes) -> float:
        """Lives lost per step, counting one loss more than seen: a chromosome driven little
        is not trusted over one driven long."""
        return (self.losses[key] + 1) / (self.steps[key] + 1)

    def best(self) -> np.ndarray:
        """Of every chromosome recorded, the one with the lowest loss rate (the first recorded
        of equals)."""
        return self.chromosomes[min(self.chromosomes, key=self.loss_rate)]


@dataclass
class SharedRun:
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


class SharedArena:
    """V vehicles in one arena: the scenario's learner start and traffic starts, each vehicle
    driven by genes of its own or by a scripted strategy (``kinds``)."""

    def __init__(self, world: World, starts: np.ndarray, kinds: np.ndarray, seed: int):
        self.world = world
        self.kinds = np.asarray(kinds, dtype=np.int64)
        count = len(self.kinds)
        self.physics = p = world._physics
        self.radius = 0.5 * math.hypot(p.length, p.width)
        self.pose = np.empty((count, 3))
        self.corners = np.empty((count, 4, 2))
        self.centres = np.empty((count, 2))
        self.memory = np.zeros((count, 2))
        self.rng = np.full(1, np.uint64(seed), dtype=np.uint64)
        for v in range(count):
            _place(v, *starts[v], p.length, p.width, self.pose, self.corners, self.centres)
            reset_memory(self.kinds[v], p.params, self.rng, self.memory[v])
        self.previous, self.previous_centres = self.corners.copy(), self.centres.copy()
        self.fresh = np.zeros(count, dtype=np.bool_)
        self.life = np.zeros(count, dtype=np.int64)
        episode = world.scenario.episode
        self.recent = np.zeros((count, episode.spin_window, 2))
        self.spin_variance = episode.spin_variance
        self.events = np.empty(count, dtype=np.int64)

    def run(self, seconds: float, genes: np.ndarray, learners: list[VehicleGA | None] | None = None,
            params: ga.GAParams | None = None, share_elites: bool = False,
            elite_count: int = 0, evidence: Evidence | None = None, check_spins: bool = False
            ) -> SharedRun:
        """Drive for ``seconds`` of simulated time. ``genes`` (V, G, world layout) drive the
        network vehicles; a vehicle with a :class:`VehicleGA` in ``learners`` learns: its
        genes row follows its current chromosome, and every life it drives (the last one as
        far as it went) goes into ``evidence``. Learning vehicles, and with ``check_spins``
        every network vehicle, lose their life when they spin in place."""
        count = len(self.kinds)
        learners = learners or [None] * count
        learning = np.array([g is not None for g in learners])
        spin_checked = learning | (check_spins & (self.kinds == RANDOM_NETWORK))
        evidence = Evidence() if evidence is None else evidence
        shown = self.life.copy()  # steps of a life going on that an earlier run recorded
        for v, learner in enumerate(learners):
            if learner is not None:
                genes[v] = learner.current
        steps = round(seconds / self.world.scenario.vehicle.dt)
        collisions, spins = np.zeros(count, dtype=np.int64), np.zeros(count, dtype=np.int64)
        trace = np.empty((steps + 1, count, 3))
        layer_sizes, gain = self.world._shape
        for t in range(steps + 1):
            trace[t] = self.pose
            detect(self.pose, self.corners, self.centres, self.previous, self.previous_centres,
                   self.fresh, spin_checked, self.life, self.recent, self.physics.walls,
                   self.physics.lookup, self.radius, self.spin_variance, self.events)
            for v in np.nonzero(self.events != ALIVE)[0]:
                spun = self.events[v] == SPUN
                spins[v] += spun
                collisions[v] += not spun
                learner = learners[v]
                if learner is not None:
                    evidence.record(learner.current, int(self.life[v] - shown[v]), losses=1)
                    learner.record(0.0 if spun else float(self.life[v]))
                    if learner.exhausted:
                        elites = (_global_elites(learners, elite_count) if share_elites
                                  else None)
                        learner.advance(params, elites)
                    genes[v] = learner.current
                shown[v] = 0
                p = self.physics
                respawn(v, self.kinds[v], self.pose, self.corners, self.centres, self.previous,
                        self.previous_centres, self.fresh, self.memory, self.life, p.length,
                        p.width, p.walls, p.lookup, p.bounds, p.params, self.rng)
            if t == steps:
                break
            p = self.physics
            drive(self.pose, self.corners, self.centres, self.previous, self.previous_centres,
                  self.fresh, self.kinds, genes, layer_sizes, gain, p.length, p.width,
                  p.wheelbase, p.distance, p.beam_cos, p.beam_sin, p.max_range, p.walls,
                  p.lookup, p.params, self.memory, self.rng, self.radius, self.life)
        for v, learner in enumerate(learners):  # a life still going counts what it has shown
            if learner is not None:
                evidence.record(learner.current, int(self.life[v] - shown[v]), losses=0)
        return SharedRun(collisions, spins, steps * self.world.scenario.vehicle.dt, trace)


def _global_elites(learners: list[VehicleGA | None], count: int) -> np.ndarray:
    """The ``count`` fittest chromosomes over every learning vehicle's current population
    (unevaluated chromosomes count as fitness 0, as in the authors' code)."""
    pools = [g for g in learners if g is not None]
    population = np.concatenate([g.population for g in pools])
    fitness = np.concatenate([g.fitness for g in pools])
    return population[np.argsort(-fitness, kind="stable")[:count]]
