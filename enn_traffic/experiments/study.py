"""One reproduction's context: its folder, whether it is quick, its progress bars, where its
whole runs go, and what its experiments compute once and share (docs/design.md, "Study").

``reproduce`` builds one :class:`Study` and hands it to every experiment as
``experiment(study)``. What the experiments share lives here and only here: the worlds they
build, every chromosome's lifetimes on a set of situations, and results asked for twice (the
controllers Table 1 chooses and later tables deploy; the crowd measurements Tables 3 and 4
both read). A new Study starts empty, so two reproductions in one process never see each
other's.

``--quick`` is one rule: every experiment's settings are a frozen dataclass with a ``quick``
field, the values that ``--quick`` replaces, and :meth:`Study.settings` applies them.
"""

from __future__ import annotations

from collections.abc import Callable, Hashable, Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TypeVar

import numpy as np
import pandas as pd

from enn_traffic.config import Scenario
from enn_traffic.config.shipped import shipped_scenario
from enn_traffic.experiments.common import Jobs, LocalRuns, RayRuns, distinct
from enn_traffic.sim.world import SituationResults, World, make_world

T = TypeVar("T")


@dataclass(frozen=True)
class Runs:
    """An experiment's runs: their GA seeds and GA overrides, and what ``--quick`` changes of
    them (``quick``: field -> value)."""

    seeds: tuple[int, ...]
    ga: Mapping[str, object] = field(default_factory=dict)
    quick: Mapping[str, object] = field(default_factory=dict)


@dataclass
class Study:
    """A reproduction into ``out``: ``quick`` settings or the full ones, progress bars or not,
    its whole runs one after another here or on Ray (``runs``)."""

    out: Path
    quick: bool = False
    progress: bool = True
    runs: LocalRuns | RayRuns = field(default_factory=LocalRuns)
    _worlds: dict[str, World] = field(default_factory=dict, repr=False)
    _lives: dict[tuple[str, int], dict[bytes, np.ndarray]] = field(default_factory=dict,
                                                                    repr=False)
    _shared: dict[Hashable, object] = field(default_factory=dict, repr=False)

    def settings(self, settings: T) -> T:
        """``settings`` as this study runs them: with their ``quick`` values in quick mode."""
        return replace(settings, **settings.quick) if self.quick else settings

    def run_all(self, jobs: Jobs) -> dict[Hashable, pd.DataFrame]:
        """Independent runs (``key -> (scenario, folder)``), each reused, resumed or done, on
        this study's executor."""
        return self.runs.map(jobs, self.progress)

    def world(self, scenario: Scenario) -> World:
        """The world of ``scenario``, built once."""
        name = scenario.model_dump_json()
        if name not in self._worlds:
            self._worlds[name] = make_world(scenario)
        return self._worlds[name]

    def lifetimes(self, scenario: Scenario, candidates: np.ndarray, key: int) -> np.ndarray:
        """Each candidate's lifetime fitness in each situation drawn from ``key`` (P, E).

        A chromosome's lives depend on it and the situations alone, and the same questions
        come again (Table 2 asks each generation about the elites it asked about the one
        before): every chromosome is driven once per study and situations."""
        candidates = np.atleast_2d(candidates)
        known = self._lives.setdefault((scenario.model_dump_json(), key), {})
        new = [row for row in distinct(candidates) if row.tobytes() not in known]
        if new:
            results = self.world(scenario).evaluate(np.array(new), key)
            fitness = SituationResults.lifetime_fitness(results.steps, results.outcome)
            known.update((row.tobytes(), lives) for row, lives in zip(new, fitness, strict=True))
        return np.stack([known[row.tobytes()] for row in candidates])

    def shared(self, key: Hashable, compute: Callable[[], T]) -> T:
        """``compute()``, once per study and ``key``: results two experiments read."""
        if key not in self._shared:
            self._shared[key] = compute()
        return self._shared[key]


def seed_runs(study: Study, name: str, runs: Runs) -> dict[int, pd.DataFrame]:
    """One run of scenario ``name`` per seed of ``runs`` (as ``study`` runs them) under
    ``runs/NAME/seedN``; experiments that share runs (Fig. 7 and Fig. 9's 19 beams) find them
    done."""
    runs = study.settings(runs)
    base = shipped_scenario(name)
    jobs = {seed: (base.with_overrides(seed=seed, ga=dict(runs.ga)),
                   study.out / "runs" / name / f"seed{seed}") for seed in runs.seeds}
    return study.run_all(jobs)
