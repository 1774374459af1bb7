"""Choosing and accepting controllers (paper §5.3–5.4): every choice on validation traffic,
never on the test traffic the tables report (:mod:`enn_traffic.core.keys`).

A run's candidates are its generations' champions and the elites it ends with, read from the
files it leaves (:class:`enn_traffic.runs.run.RunOutputs`)."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from enn_traffic.core import keys
from enn_traffic.experiments.common import distinct
from enn_traffic.experiments.families import Family, family_runs, run_dir
from enn_traffic.runs.evaluate import EVALUATION_KEY
from enn_traffic.runs.run import RunOutputs

if TYPE_CHECKING:
    from enn_traffic.experiments.study import Study

# Candidates are chosen on validation traffic, never on the test traffic of Tables 1 and 2.
VALIDATION_KEY = keys.CHOOSING.start
# Table 2 (§5.4.1): a strategy is added once the fitness on every strategy included so far
# exceeds 80% of the accepted fitness, judged on validation traffic for the TOP_CANDIDATES
# fittest of a generation, since a generation's best fitness alone is mostly luck: a candidate
# that passes on test_situations situations must pass again on recheck_situations other ones
# (ACCEPTANCE_KEY) by its mean less ACCEPTANCE_ERRORS standard errors, so that a candidate just
# under the threshold seldom passes by the luck of one of the many checks a run makes.
TOP_CANDIDATES = 5
ACCEPTANCE_KEY = keys.TABLE2_ACCEPTANCE.start
ACCEPTANCE_ERRORS = 2.0
# The best of a few hundred candidates on test_situations situations is partly luck too: the
# RECHECKED best are scored again on recheck_situations validation situations before the choice.
RECHECKED = 10


def lifetimes(study: Study, family: Family, candidates: np.ndarray, strategy: int, key: int,
              situations: int | None = None) -> np.ndarray:
    """Each candidate's fitness in each of the situations (``test_situations`` unless given) drawn
    from ``key`` (P, E), every chromosome driven once per study."""
    scenario = family.scenario(strategy, situations or family.test_situations)
    return study.lifetimes(scenario, candidates, key)


def mean_fitness(study: Study, family: Family, candidates: np.ndarray, strategy: int, key: int,
                 situations: int | None = None) -> np.ndarray:
    """Mean fitness of each candidate over the situations (``test_situations`` unless given)
    drawn from ``key``."""
    return lifetimes(study, family, candidates, strategy, key, situations).mean(axis=1)


def lower_bound(study: Study, family: Family, candidates: np.ndarray, strategy: int, key: int,
                situations: int) -> np.ndarray:
    """Each candidate's mean fitness over ``situations`` situations drawn from ``key``, less
    ``ACCEPTANCE_ERRORS`` standard errors of that mean."""
    fitness = lifetimes(study, family, candidates, strategy, key, situations)
    error = fitness.std(axis=1, ddof=1) / np.sqrt(situations)
    return fitness.mean(axis=1) - ACCEPTANCE_ERRORS * error


def candidates(folder: Path, whole_population: bool = False) -> np.ndarray:
    """A run's controllers to choose from: every generation's best chromosome (the run's best
    alone for a run that kept none) and the elites at the head of its final population (or,
    with ``whole_population``, all of it), each once."""
    outputs = RunOutputs.load(folder)
    kept = len(outputs.population) if whole_population else max(outputs.elite_count, 1)
    return distinct(np.concatenate([outputs.champions, outputs.population[:kept]]))


def validation(study: Study, family: Family, candidates: np.ndarray, strategies: list[int],
               situations: int | None = None) -> np.ndarray:
    """Mean fitness (candidates, strategies) on validation traffic."""
    return np.stack([mean_fitness(study, family, candidates, s, VALIDATION_KEY, situations)
                     for s in strategies], axis=1)


def pick(study: Study, family: Family, candidates: np.ndarray, strategies: list[int]
         ) -> np.ndarray:
    """The candidate whose worst strategy does best on validation traffic, as Table 2's
    acceptance asks of every included strategy (§5.4.1): every candidate on
    ``test_situations`` situations, then the ``RECHECKED`` best on ``recheck_situations``."""
    return scored_pick(study, family, candidates, strategies)[0]


def scored_pick(study: Study, family: Family, candidates: np.ndarray, strategies: list[int]
                ) -> tuple[np.ndarray, float]:
    """:func:`pick`, and the picked candidate's worst strategy on the recheck."""
    worst = validation(study, family, candidates, strategies).min(axis=1)
    best = candidates[np.argsort(-worst, kind="stable")[:RECHECKED]]
    worst = validation(study, family, best, strategies, family.recheck_situations).min(axis=1)
    return best[int(np.argmax(worst))], float(worst.max())


def accepts(study: Study, family: Family, candidates: np.ndarray, strategies: list[int],
            threshold: float) -> bool:
    """Table 2's acceptance (§5.4.1): one of ``candidates`` reaches ``threshold`` on every
    strategy in ``test_situations`` validation situations, and its mean less
    ``ACCEPTANCE_ERRORS`` standard errors does so in ``recheck_situations`` others."""
    worst = validation(study, family, candidates, strategies).min(axis=1)
    passing = candidates[worst >= threshold]
    if len(passing) == 0:
        return False
    bounds = np.stack([lower_bound(study, family, passing, s, ACCEPTANCE_KEY,
                                   family.recheck_situations) for s in strategies], axis=1)
    return bool((bounds.min(axis=1) >= threshold).any())


def fitness_on_test_traffic(study: Study, family: Family, chromosome: np.ndarray, strategy: int
                            ) -> float:
    """Mean fitness over the ``table_situations`` test situations of a strategy's traffic."""
    return float(mean_fitness(study, family, chromosome, strategy, EVALUATION_KEY,
                              family.table_situations)[0])


def held_out(study: Study, family: Family, strategy: int, seed: int) -> np.ndarray | None:
    """Each generation's best chromosome of a run, scored again on the strategy's test traffic
    (None for a run without any): what the run learned, apart from the luck of its
    own traffic, which inflates a generation's best training fitness."""
    folder = run_dir(family, study.out / family.folder, strategy, seed)
    champions = RunOutputs.load(folder).champions
    return (mean_fitness(study, family, champions, strategy, EVALUATION_KEY)
            if len(champions) else None)


def specialists(study: Study, family: Family) -> dict[int, np.ndarray]:
    """Per strategy: the best of its runs' candidates, judged on validation traffic of that
    same strategy (the runs done first if need be), chosen once per study: Table 1, the
    replay against closed loop and Tables 3–4 deploy the same controllers."""
    def choose() -> dict[int, np.ndarray]:
        pools = evolved_candidates(study, family)
        return {strategy: pick(study, family, pools[strategy], [strategy])
                for strategy in family.strategies}

    return study.shared(("specialists", repr(family)), choose)


def evolved_candidates(study: Study, family: Family) -> dict[int, np.ndarray]:
    """Per strategy: the controllers individual learning evolved on it (§5.3; every run's
    :func:`candidates`, the runs done first if need be), from which Table 1 and §5.5
    choose."""
    family_runs(study, family)
    out = study.out / family.folder
    return {strategy: np.concatenate([candidates(run_dir(family, out, strategy, seed))
                                      for seed in family.seeds])
            for strategy in family.strategies}


def final_population(study: Study, family: Family, strategy: int, chosen: np.ndarray
                     ) -> np.ndarray:
    """The final population of the run that produced ``chosen``."""
    out = study.out / family.folder
    for seed in family.seeds:
        folder = run_dir(family, out, strategy, seed)
        if any(np.array_equal(row, chosen) for row in candidates(folder)):
            return RunOutputs.load(folder).population
    raise ValueError(f"no run of {family.name(strategy)} produced the chosen controller")
