"""The genetic algorithm of paper §5: pure operators over the population array.

Its settings are a scenario's ``[ga]`` (:class:`~enn_traffic.config.GAConfig`, whose defaults
are the paper's §5: population 200, tournaments of 10, one-point crossover with probability 1
and the cut at round(Normal(0.95, 0.05) × length), per-gene mutation with probability 0.1 that
replaces the gene by U[-1, 1], children replace their parents). Elitism is an option.

The GA never knows how fitness is computed: a run asks for the chromosomes to evaluate
(:func:`ask`), evaluates them however it likes and tells the GA their fitness (:func:`tell`),
which breeds the next generation; :func:`generations` is that loop, the one every run, bench
and baseline drives. Every operator takes the random generator explicitly; the
state is a small dataclass that checkpoints to one ``.npz`` file.
"""

from __future__ import annotations

import io
import json
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from enn_traffic.config import GAConfig
from enn_traffic.core.errors import InputError
from enn_traffic.core.io import write_atomic


def initial_population(
    rng: np.random.Generator, population_size: int, chromosome_length: int, init_range: float
) -> np.ndarray:
    """Genes i.i.d. U[-init_range, init_range] (docs/design.md, "The authors' code" 5)."""
    return rng.uniform(-init_range, init_range, size=(population_size, chromosome_length))


def tournament_select(
    rng: np.random.Generator, fitness: np.ndarray, count: int, tournament_size: int
) -> np.ndarray:
    """Indices of ``count`` winners; each tournament draws contestants with replacement and the
    fittest wins (the first drawn on a tie)."""
    contestants = rng.integers(0, len(fitness), size=(count, tournament_size))
    return contestants[np.arange(count), np.argmax(fitness[contestants], axis=1)]


def one_point_crossover(
    rng: np.random.Generator,
    first: np.ndarray,
    second: np.ndarray,
    probability: float,
    cut_mean: float,
    cut_std: float,
) -> np.ndarray:
    """Two children per pair of parents, stacked ``[first children; second children]``.

    The cut c = round(Normal(cut_mean, cut_std) × length), clipped to [1, length - 1]: genes
    before c come from one parent, genes from c on from the other. Pairs that do not cross
    (probability ``1 - probability``) pass unchanged.
    """
    pairs, length = first.shape
    cuts = np.rint(rng.normal(cut_mean, cut_std, size=pairs) * length).astype(int)
    cuts = np.clip(cuts, 1, max(length - 1, 1))
    crossing = rng.random(pairs) < probability
    tail = (np.arange(length)[None, :] >= cuts[:, None]) & crossing[:, None]
    child_a = np.where(tail, second, first)
    child_b = np.where(tail, first, second)
    return np.concatenate([child_a, child_b])


def mutate(
    rng: np.random.Generator, population: np.ndarray, probability: float, init_range: float
) -> np.ndarray:
    """Replace each gene with probability ``probability`` by a fresh U[-init_range, init_range]."""
    mask = rng.random(population.shape) < probability
    fresh = rng.uniform(-init_range, init_range, size=population.shape)
    return np.where(mask, fresh, population)


def next_generation(
    rng: np.random.Generator, population: np.ndarray, fitness: np.ndarray, params: GAConfig
) -> np.ndarray:
    """Selection, crossover and mutation; the children (after ``elite_count`` unchanged elites)
    replace the parents."""
    size = len(population)
    elites = population[np.argsort(-fitness, kind="stable")[: params.elite_count]]
    children_needed = size - len(elites)
    pairs = (children_needed + 1) // 2
    winners = tournament_select(rng, fitness, 2 * pairs, params.tournament_size)
    children = one_point_crossover(
        rng,
        population[winners[:pairs]],
        population[winners[pairs:]],
        params.crossover_probability,
        params.crossover_cut_mean,
        params.crossover_cut_std,
    )[:children_needed]
    children = mutate(rng, children, params.mutation_probability, params.init_range)
    return np.concatenate([elites, children])


@dataclass
class GAState:
    """Everything a run needs to continue: the population still to be evaluated, its generation
    number, the generator state, the best controller found so far, and each finished
    generation's best chromosome (``champions``, one row per generation)."""

    generation: int
    population: np.ndarray
    rng: np.random.Generator
    best_chromosome: np.ndarray | None = None
    best_fitness: float = -np.inf
    fingerprint: str = ""
    extra: dict = field(default_factory=dict)
    champions: np.ndarray | None = None

    def save(self, path: Path) -> None:
        """Write atomically: a crash never leaves a half-written checkpoint in place."""
        best = self.best_chromosome if self.best_chromosome is not None else np.empty(0)
        buffer = io.BytesIO()
        np.savez(
            buffer,
            generation=self.generation,
            population=self.population,
            rng_state=json.dumps(self.rng.bit_generator.state),
            best_chromosome=best,
            best_fitness=self.best_fitness,
            fingerprint=self.fingerprint,
            extra=json.dumps(self.extra),
            champions=self.champions if self.champions is not None else np.empty(0),
        )
        write_atomic(path, lambda handle: handle.write(buffer.getvalue()), binary=True)

    @classmethod
    def load(cls, path: Path) -> GAState:
        try:
            with np.load(path, allow_pickle=False) as data:
                rng = np.random.default_rng()
                rng.bit_generator.state = json.loads(str(data["rng_state"]))
                best = data["best_chromosome"]
                champions = data["champions"] if "champions" in data.files else np.empty(0)
                state = cls(
                    generation=int(data["generation"]),
                    population=data["population"].copy(),
                    rng=rng,
                    best_chromosome=best.copy() if best.size else None,
                    best_fitness=float(data["best_fitness"]),
                    fingerprint=str(data["fingerprint"]),
                    extra=json.loads(str(data["extra"])),
                    champions=champions.copy() if champions.size else None,
                )
        except Exception as exc:  # a damaged archive raises many types (zipfile, numpy, json)
            raise InputError(f"checkpoint is unreadable or corrupted ({type(exc).__name__}: "
                             f"{exc})", path) from None
        if not isinstance(state.extra, dict):
            raise InputError(f"holds a {type(state.extra).__name__}, not a mapping", path,
                             "extra")
        if state.population.dtype.kind not in "iufc":
            raise InputError(f"checkpoint population holds {state.population.dtype} values, "
                             "not numbers", path)
        if not np.all(np.isfinite(state.population)):
            raise InputError("checkpoint population holds NaN or inf", path)
        return state


def ask(state: GAState) -> np.ndarray:
    """The chromosomes whose fitness the GA needs next: the state's population."""
    return state.population


def tell(state: GAState, fitness: np.ndarray, params: GAConfig) -> GAState:
    """The state after the generation of ``ask(state)`` scored ``fitness``: its best
    chromosome recorded as the generation's champion (and as the best so far when it beats
    it), the next generation bred from it (:func:`next_generation`, drawing from the state's
    generator), the generation number advanced."""
    best = int(np.argmax(fitness))
    champion = state.population[best][None, :]
    improved = fitness[best] > state.best_fitness
    return replace(
        state,
        generation=state.generation + 1,
        population=next_generation(state.rng, state.population, fitness, params),
        best_chromosome=state.population[best].copy() if improved else state.best_chromosome,
        best_fitness=float(fitness[best]) if improved else state.best_fitness,
        champions=champion if state.champions is None
        else np.concatenate([state.champions, champion]),
    )


def generations(state: GAState, evaluate: Callable[[np.ndarray, int], object],
                params: GAConfig) -> Iterator[tuple[GAState, np.ndarray, object]]:
    """Ask, evaluate, tell, without end: after each generation, the new state, the
    population just evaluated and what ``evaluate(population, generation)`` returned (its
    ``fitness`` is what the GA is told). The caller stops when it has seen enough."""
    while True:
        population = ask(state)
        evaluated = evaluate(population, state.generation)
        state = tell(state, evaluated.fitness, params)
        yield state, population, evaluated
