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

from enn_traffic.config import GAConfig
from enn_traffic.learning import ga


@dataclass
class VehicleGA:
    """One vehicle's own population, evaluated a chromosome per life (reference §7.1): a
    chromosome's fitness is the steps its life lasted (0 for a spin), or the life cap when it
    reached it. ``lives`` counts the lives it lost, ``tried`` the chromosomes whose evaluation
    ended (a lost life or the cap). A ``finished`` vehicle has stopped learning and keeps its
    current chromosome (the authors' finishing rule, reference §7.5)."""

    population: np.ndarray  # (P, G), the world's gene layout
    rng: np.random.Generator
    fitness: np.ndarray = field(init=False)
    index: int = 0
    generation: int = 0
    lives: int = 0
    tried: int = 0
    bred_from: tuple[np.ndarray, np.ndarray] | None = None  # last whole generation, fitness
    finished: bool = False

    def __post_init__(self):
        self.fitness = np.zeros(len(self.population))

    @property
    def current(self) -> np.ndarray:
        return self.population[self.index]

    def record(self, fitness: float) -> None:
        """The current chromosome's evaluation ended with ``fitness``."""
        self.fitness[self.index] = fitness
        self.index += 1
        self.tried += 1

    def finish(self, fitness: float) -> None:
        """The current chromosome lived long enough: the vehicle keeps it and stops learning
        (reference §7.5)."""
        self.fitness[self.index] = fitness
        self.tried += 1
        self.finished = True

    @property
    def exhausted(self) -> bool:
        return self.index >= len(self.population)

    def advance(self, params: GAConfig, global_elites: np.ndarray | None = None,
                from_best: bool = False) -> None:
        """The next generation; ``global_elites`` (the best chromosomes of all vehicles,
        reference §7.4) replace its own elites when given. ``from_best``: the authors'
        breeding, the children of the population's best P − E only (reference §7.4), where
        ours draws the tournaments from all P."""
        self.bred_from = (self.population.copy(), self.fitness.copy())
        elites = 0 if global_elites is None else len(global_elites)
        if from_best and elites:
            best = np.argsort(-self.fitness, kind="stable")[: len(self.population) - elites]
            children = ga.next_generation(self.rng, self.population[best], self.fitness[best],
                                          params.model_copy(update={"elite_count": 0}))
            population = np.concatenate([global_elites, children])
        else:
            population = ga.tell(ga.GAState(self.generation, self.population, self.rng),
                                 self.fitness, params).population
            if elites:
                population[:elites] = global_elites
        self.population, self.index, self.generation = population, 0, self.generation + 1
        self.fitness = np.zeros(len(population))

    def evolved(self) -> np.ndarray:
        """What the vehicle drives once it stops learning, the authors' rule (reference §7.5):
        the chromosome it finished with; else the fittest chromosome of its last whole
        generation (the first of equals); before it has finished one, the fittest it has tried
        of its first, or its first chromosome."""
        if self.finished:
            return self.current
        population, fitness = self.bred_from or (self.population[: max(self.index, 1)],
                                                 self.fitness[: max(self.index, 1)])
        return population[int(np.argmax(fitness))]


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
    (``own[v]``). A chromosome whose life reaches ``life_cap`` steps (0: no cap) scores the
    cap and the vehicle drives on, from where it is, with its next chromosome
    (docs/departures.md, "Learning while driving"). With ``finish_steps`` (the authors' rule,
    reference §7.5; 0: never), a vehicle whose life lasted that long keeps its chromosome and
    stops learning; it still loses lives and respawns. ``breed_from_best``: the authors'
    breeding (:meth:`VehicleGA.advance`)."""

    def __init__(self, learners: list[VehicleGA | None], params: GAConfig,
                 share_elites: bool = False, elite_count: int = 0,
                 evidence: Evidence | None = None, life_cap: int = 0, finish_steps: int = 0,
                 breed_from_best: bool = False):
        self.learners = learners
        self.params = params
        self.share_elites = share_elites
        self.elite_count = elite_count
        self.evidence = Evidence() if evidence is None else evidence
        self.own = [Evidence() for _ in learners]
        self.life_cap = life_cap
        self.finish_steps = finish_steps
        self.breed_from_best = breed_from_best

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
        self.learners[vehicle].lives += 1
        return self._next(vehicle, 0.0 if spun else float(steps), unseen_steps, losses=1)

    def _finishes(self, vehicle: int, fitness: float) -> bool:
        learner = self.learners[vehicle]
        if not learner.finished and self.finish_steps and fitness >= self.finish_steps:
            learner.finish(fitness)
        return learner.finished

    def life_capped(self, vehicle: int, unseen_steps: int) -> np.ndarray:
        """The vehicle's chromosome drove ``life_cap`` steps without losing its life: record
        it, and give the chromosome it drives on with."""
        return self._next(vehicle, float(self.life_cap), unseen_steps, losses=0)

    def _next(self, vehicle: int, fitness: float, unseen_steps: int, losses: int
              ) -> np.ndarray:
        learner = self.learners[vehicle]
        self.evidence.record(learner.current, unseen_steps, losses)
        self.own[vehicle].record(learner.current, unseen_steps, losses)
        if self._finishes(vehicle, fitness):
            return learner.current
        learner.record(fitness)
        if learner.exhausted:
            elites = (global_elites(self.learners, self.elite_count) if self.share_elites
                      else None)
            learner.advance(self.params, elites, self.breed_from_best)
        return learner.current

    def still_driving(self, vehicle: int, unseen_steps: int, life_steps: int = 0) -> None:
        """The run ends with the vehicle's life going on, ``life_steps`` long: what it has
        shown counts, and a life long enough finishes the vehicle as its end would."""
        self.evidence.record(self.learners[vehicle].current, unseen_steps, losses=0)
        self.own[vehicle].record(self.learners[vehicle].current, unseen_steps, losses=0)
        self._finishes(vehicle, float(life_steps))

    def own_controllers(self) -> np.ndarray:
        """Each learning vehicle's controller by re-ranking (V, G): of the chromosomes it drove
        itself, the one that lost fewest lives per step in its own lives
        (:meth:`Evidence.best`)."""
        return np.stack([own.best() for own, learner in zip(self.own, self.learners,
                                                             strict=True) if learner is not None])

    def evolved_controllers(self) -> np.ndarray:
        """Each learning vehicle's controller from its evolved population (V, G): the
        authors' rule, :meth:`VehicleGA.evolved`."""
        return np.stack([learner.evolved() for learner in self.learners if learner is not None])

    def learner_rows(self) -> list[dict[str, int]]:
        """Per learning vehicle: generations bred, lives lost, chromosomes tried, and whether
        it finished (with ``finish_steps``)."""
        return [{"learner": k, "generations_bred": g.generation, "lives": g.lives,
                 "chromosomes_tried": g.tried} | ({"finished": int(g.finished)}
                                                  if self.finish_steps else {})
                for k, g in enumerate(g for g in self.learners if g is not None)]


def global_elites(learners: list[VehicleGA | None], count: int) -> np.ndarray:
    """The ``count`` fittest chromosomes over every learning vehicle's current population
    (unevaluated chromosomes count as fitness 0, as in the authors' code)."""
    pools = [g for g in learners if g is not None]
    population = np.concatenate([g.population for g in pools])
    fitness = np.concatenate([g.fitness for g in pools])
    return population[np.argsort(-fitness, kind="stable")[:count]]
