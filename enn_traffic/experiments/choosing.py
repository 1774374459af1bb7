"""Choosing and accepting controllers (paper §5.3–5.4): every choice on validation traffic,
never on the test traffic the tables report (:mod:`enn_traffic.keys`).

A run's candidates are its generations' champions and the elites it ends with, read from the
files it leaves (:class:`enn_traffic.runner.RunOutputs`)."""

from __future__ import annotations

from functools import cache
from pathlib import Path

import numpy as np

from enn_traffic import keys
from enn_traffic.deploy import EVALUATION_KEY
from enn_traffic.experiments.common import distinct
from enn_traffic.experiments.protocol import (
    ARENA,
    Family,
    family_runs,
    run_dir,
    strategy_world,
)
from enn_traffic.runner import RunOutputs
from enn_traffic.sim.world import EpisodeResults

# Candidates are chosen on validation traffic, never on the test traffic of Tables 1 and 2.
VALIDATION_KEY = keys.VALIDATION.start
# Table 2 (§5.4.1): a strategy is added once the fitness on every strategy included so far
# exceeds 80% of the accepted fitness, judged on validation traffic for the TOP_CANDIDATES
# fittest of a generation, since a generation's best fitness alone is mostly luck: a candidate
# that passes on test_episodes situations must pass again on recheck_episodes other ones
# (ACCEPTANCE_KEY) by its mean less ACCEPTANCE_ERRORS standard errors, so that a candidate just
# under the threshold seldom passes by the luck of one of the many checks a run makes.
TOP_CANDIDATES = 5
ACCEPTANCE_KEY = keys.ACCEPTANCE.start
ACCEPTANCE_ERRORS = 2.0
# The best of a few hundred candidates on test_episodes situations is partly luck too: the
# RECHECKED best are scored again on recheck_episodes validation situations before the choice.
RECHECKED = 10


def episode_results(family: Family, candidates: np.ndarray, strategy: int, key: int,
                    episodes: int | None = None) -> EpisodeResults:
    """Each candidate driven in the episodes (``test_episodes`` unless given) drawn from
    ``key``."""
    return strategy_world(family, strategy, episodes).evaluate(np.atleast_2d(candidates), key)


# Each chromosome's lifetime fitness per situation, by (family, strategy, key, episodes): a
# chromosome's lives depend on it and the situations alone, and the same questions come
# again (Table 2 asks each generation about the elites it asked about the one before).
_LIVES: dict[tuple, dict[bytes, np.ndarray]] = {}


def lifetimes(family: Family, candidates: np.ndarray, strategy: int, key: int,
              episodes: int | None = None) -> np.ndarray:
    """Each candidate's fitness in each of the episodes drawn from ``key`` (P, E), every
    chromosome driven once per process."""
    candidates = np.atleast_2d(candidates)
    episodes = episodes or family.test_episodes
    known = _LIVES.setdefault((family, strategy, key, episodes), {})
    new = [row for row in distinct(candidates) if row.tobytes() not in known]
    if new:
        results = episode_results(family, np.array(new), strategy, key, episodes)
        fitness = EpisodeResults.lifetime_fitness(results.steps, results.outcome)
        known.update((row.tobytes(), lives) for row, lives in zip(new, fitness, strict=True))
    return np.stack([known[row.tobytes()] for row in candidates])


def mean_fitness(family: Family, candidates: np.ndarray, strategy: int, key: int,
                 episodes: int | None = None) -> np.ndarray:
    """Mean fitness of each candidate over the episodes (``test_episodes`` unless given)
    drawn from ``key``."""
    return lifetimes(family, candidates, strategy, key, episodes).mean(axis=1)


def lower_bound(family: Family, candidates: np.ndarray, strategy: int, key: int,
                episodes: int) -> np.ndarray:
    """Each candidate's mean fitness over ``episodes`` situations drawn from ``key``, less
    ``ACCEPTANCE_ERRORS`` standard errors of that mean."""
    fitness = lifetimes(family, candidates, strategy, key, episodes)
    error = fitness.std(axis=1, ddof=1) / np.sqrt(episodes)
    return fitness.mean(axis=1) - ACCEPTANCE_ERRORS * error


def candidates(folder: Path, whole_population: bool = False) -> np.ndarray:
    """A run's controllers to choose from: every generation's best chromosome (the run's best
    alone for a run that kept none) and the elites at the head of its final population (or,
    with ``whole_population``, all of it), each once."""
    outputs = RunOutputs.load(folder)
    kept = len(outputs.population) if whole_population else max(outputs.elite_count, 1)
    return distinct(np.concatenate([outputs.champions, outputs.population[:kept]]))


def validation(family: Family, candidates: np.ndarray, strategies: list[int],
               episodes: int | None = None) -> np.ndarray:
    """Mean fitness (candidates, strategies) on validation traffic."""
    return np.stack([mean_fitness(family, candidates, s, VALIDATION_KEY, episodes)
                     for s in strategies], axis=1)


def pick(family: Family, candidates: np.ndarray, strategies: list[int]) -> np.ndarray:
    """The candidate whose worst strategy does best on validation traffic, as Table 2's
    acceptance asks of every included strategy (§5.4.1): every candidate on
    ``test_episodes`` situations, then the ``RECHECKED`` best on ``recheck_episodes``."""
    return scored_pick(family, candidates, strategies)[0]


def scored_pick(family: Family, candidates: np.ndarray, strategies: list[int]
                ) -> tuple[np.ndarray, float]:
    """:func:`pick`, and the picked candidate's worst strategy on the recheck."""
    worst = validation(family, candidates, strategies).min(axis=1)
    best = candidates[np.argsort(-worst, kind="stable")[:RECHECKED]]
    worst = validation(family, best, strategies, family.recheck_episodes).min(axis=1)
    return best[int(np.argmax(worst))], float(worst.max())


def accepts(family: Family, candidates: np.ndarray, strategies: list[int],
            threshold: float) -> bool:
    """Table 2's acceptance (§5.4.1): one of ``candidates`` reaches ``threshold`` on every
    strategy in ``test_episodes`` validation situations, and its mean less
    ``ACCEPTANCE_ERRORS`` standard errors does so in ``recheck_episodes`` others."""
    worst = validation(family, candidates, strategies).min(axis=1)
    passing = candidates[worst >= threshold]
    if len(passing) == 0:
        return False
    bounds = np.stack([lower_bound(family, passing, s, ACCEPTANCE_KEY, family.recheck_episodes)
                       for s in strategies], axis=1)
    return bool((bounds.min(axis=1) >= threshold).any())


def fitness_on_test_traffic(family: Family, chromosome: np.ndarray, strategy: int) -> float:
    """Mean fitness over the ``table_episodes`` test situations of a strategy's traffic."""
    return float(mean_fitness(family, chromosome, strategy, EVALUATION_KEY,
                              family.table_episodes)[0])


def held_out(family: Family, out: Path, strategy: int, seed: int) -> np.ndarray | None:
    """Each generation's best chromosome of a run, scored again on the strategy's test traffic
    (None for a run without any): what the run learned, apart from the luck of its
    own traffic, which inflates a generation's best training fitness."""
    champions = RunOutputs.load(run_dir(family, out, strategy, seed)).champions
    return mean_fitness(family, champions, strategy, EVALUATION_KEY) if len(champions) else None


def specialists(family: Family, out: Path, progress: bool) -> dict[int, np.ndarray]:
    """Per strategy: the best of its runs' candidates, judged on validation traffic of that
    same strategy (the runs done first if need be)."""
    _evolved_candidates(family, out, progress)
    return dict(_specialists(family, out))


@cache
def _specialists(family: Family, out: Path) -> dict[int, np.ndarray]:
    """:func:`specialists` of finished runs, chosen once per process: Table 1, the replay
    against closed loop and Tables 3–4 deploy the same controllers."""
    pools = _evolved_candidates(family, out, progress=False)
    return {strategy: pick(family, pools[strategy], [strategy]) for strategy in family.strategies}


def _evolved_candidates(family: Family, out: Path, progress: bool) -> dict[int, np.ndarray]:
    """Per strategy: every run's candidates (:func:`candidates`; the runs done first if need
    be)."""
    family_runs(family, out, progress)
    return {strategy: np.concatenate([
                candidates(run_dir(family, out, strategy, seed))
                for seed in family.seeds])
            for strategy in family.strategies}  # fmt: skip


def evolved_candidates(out: Path, quick: bool, progress: bool, family: Family = ARENA
                       ) -> dict[int, np.ndarray]:
    """Per strategy: the controllers individual learning evolved on it (§5.3), from which
    Table 1 and §5.5 choose."""
    family = family.settings(quick)
    return _evolved_candidates(family, out / family.folder, progress)


def final_population(family: Family, out: Path, strategy: int, chosen: np.ndarray,
                     quick: bool) -> np.ndarray:
    """The final population of the run that produced ``chosen``."""
    family = family.settings(quick)
    out = out / family.folder
    for seed in family.seeds:
        folder = run_dir(family, out, strategy, seed)
        if any(np.array_equal(row, chosen) for row in candidates(folder)):
            return RunOutputs.load(folder).population
    raise ValueError(f"no run of {family.name(strategy)} produced the chosen controller")


def trained_controllers(out: Path, quick: bool, progress: bool, family: Family = ARENA
                        ) -> dict[int, np.ndarray]:
    """Per strategy: the controller Table 1 deploys (trained on that strategy alone)."""
    family = family.settings(quick)
    return specialists(family, out / family.folder, progress)
