"""Learning while driving (paper §5.5; docs/design.md, "The authors' code" 6): each learning
vehicle evolves its own population, a chromosome per life, and the vehicles share what they
learn — the best chromosomes of all of them replace each one's elites, and what every vehicle
saw of a chromosome is pooled. What each vehicle saw itself is also kept apart, so that each
can end with a controller of its own (§5.5.2: "a customized solution for each different
vehicle").

The world that drives the vehicles (:class:`enn_traffic.sim.crowd.Crowd`) knows nothing of the
GA: it calls back :class:`OnlineLearning` when a learning vehicle's life ends.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from enn_traffic.evolution import ga


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
        state = ga.tell(ga.GAState(self.generation, self.population, self.rng), self.fitness,
                        params)
        population = state.population
        if global_elites is not None and len(global_elites):
            population[: len(global_elites)] = global_elites
        self.population, self.index, self.generation = population, 0, state.generation
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


class OnlineLearning:
    """The learning vehicles of a crowd, as the crowd calls them back: ``learners[v]`` is
    vehicle v's own GA, or None for a vehicle that does not learn. With ``share_elites``, an
    exhausted population breeds with the ``elite_count`` best chromosomes of all vehicles
    (reference §7.4); every life goes into the pooled ``evidence`` and into the vehicle's own
    (``own[v]``)."""

    def __init__(self, learners: list[VehicleGA | None], params: ga.GAParams,
                 share_elites: bool = False, elite_count: int = 0,
                 evidence: Evidence | None = None):
        self.learners = learners
        self.params = params
        self.share_elites = share_elites
        self.elite_count = elite_count
        self.evidence = Evidence() if evidence is None else evidence
        self.own = [Evidence() for _ in learners]

    def learns(self, vehicle: int) -> bool:
        return self.learners[vehicle] is not None

    def current(self, vehicle: int) -> np.ndarray:
        """The chromosome the vehicle drives with now."""
        return self.learners[vehicle].current

    def life_ended(self, vehicle: int, steps: int, unseen_steps: int, spun: bool
                   ) -> np.ndarray:
        """The vehicle's life ended after ``steps`` steps (``unseen_steps`` of them not yet in
        the evidence) by a collision or a spin: record it, and give the chromosome of its next
        life."""
        learner = self.learners[vehicle]
        self.evidence.record(learner.current, unseen_steps, losses=1)
        self.own[vehicle].record(learner.current, unseen_steps, losses=1)
        learner.record(0.0 if spun else float(steps))
        if learner.exhausted:
            elites = (global_elites(self.learners, self.elite_count) if self.share_elites
                      else None)
            learner.advance(self.params, elites)
        return learner.current

    def still_driving(self, vehicle: int, unseen_steps: int) -> None:
        """The run ends with the vehicle's life going on: what it has shown counts."""
        self.evidence.record(self.learners[vehicle].current, unseen_steps, losses=0)
        self.own[vehicle].record(self.learners[vehicle].current, unseen_steps, losses=0)

    def own_controllers(self) -> np.ndarray:
        """Each learning vehicle's controller (V, G): of the chromosomes it drove itself, the
        one that lost fewest lives per step in its own lives (:meth:`Evidence.best`)."""
        return np.stack([own.best() for own, learner in zip(self.own, self.learners,
                                                             strict=True) if learner is not None])


def global_elites(learners: list[VehicleGA | None], count: int) -> np.ndarray:
    """The ``count`` fittest chromosomes over every learning vehicle's current population
    (unevaluated chromosomes count as fitness 0, as in the authors' code)."""
    pools = [g for g in learners if g is not None]
    population = np.concatenate([g.population for g in pools])
    fitness = np.concatenate([g.fitness for g in pools])
    return population[np.argsort(-fitness, kind="stable")[:count]]
