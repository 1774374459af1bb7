"""Incremental evolution (paper §5.4.1): one controller for all four strategies, evolved a
strategy at a time. Iteration k evolves on strategies 1..k together (fitness: the mean over
them), starting from the population iteration k − 1 ended with, and stops once a candidate is
accepted on every included strategy (:func:`enn_traffic.experiments.choosing.accepts`)."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from enn_traffic.experiments.choosing import (
    ACCEPTANCE_ERRORS,
    TOP_CANDIDATES,
    accepts,
    candidates,
    scored_pick,
)
from enn_traffic.experiments.common import run_or_reuse
from enn_traffic.experiments.families import Family
from enn_traffic.learning.evaluators import MeanOverWorlds
from enn_traffic.runs.run import RunOutputs
from enn_traffic.sim.world import make_world

if TYPE_CHECKING:
    from enn_traffic.experiments.study import Study


@dataclass(frozen=True)
class Iteration:
    """One iteration's result: the strategies it evolved on, its generations, whether it was
    accepted before its generations ran out, the controller chosen from its candidates on
    validation traffic and that controller's worst included strategy there."""

    included: list[int]
    generations: int
    accepted: bool
    chosen: np.ndarray
    worst: float


def incremental_evolution(study: Study, family: Family, out: Path, seed: int
                          ) -> list[Iteration]:
    """One incremental evolution from GA seed ``seed``, its runs in ``out/iterationK``."""
    threshold = family.threshold
    base = family.scenario(1)
    population, iterations = None, []
    for iteration in range(1, len(family.strategies) + 1):
        ga = {"generations": family.incremental_max_generations, **family.ga}
        # the acceptance rule is part of the run's settings: a run stopped by another is redone
        rule = (f"Incremental evolution (§5.4.1), iteration {iteration}: stops when one of the "
                f"{TOP_CANDIDATES} fittest reaches {threshold:g} steps on every included "
                f"strategy in {family.test_situations} validation situations, and by its mean "
                f"less {ACCEPTANCE_ERRORS:g} standard errors in {family.recheck_situations} "
                "others.")
        sc = base.with_overrides(name=f"incremental_{iteration}", description=rule, seed=seed,
                                 ga=ga)
        included = family.strategies[:iteration]
        scenarios = [family.scenario(s) for s in included]
        worlds = [make_world(sc) for sc in scenarios]

        def accepted(population, fitness, included=included):
            fittest = population[np.argsort(-fitness, kind="stable")[:TOP_CANDIDATES]]
            return accepts(study, family, fittest, included, threshold)

        folder = out / f"iteration{iteration}"
        table = run_or_reuse(sc, folder, study.progress, evaluator=MeanOverWorlds(worlds),
                             initial_population=population, stop=accepted, others=scenarios)
        outputs = RunOutputs.load(folder)
        population = outputs.population
        chosen, worst = scored_pick(study, family, candidates(folder), included)
        iterations.append(Iteration(included, len(table), outputs.stopped, chosen, worst))
    return iterations
