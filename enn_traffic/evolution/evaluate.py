"""Evaluators: how a population's fitness gets computed (DESIGN.md, "Scale-out").

The GA calls ``evaluator.evaluate(population) -> EpisodeResults`` and nothing else. ``local``
runs the compiled batch in this process (numba threads over the cores); ``process`` splits the
population into chunks over a process pool, each worker building its own world once. Results
do not depend on the backend or the number of workers.
"""

from __future__ import annotations

import multiprocessing
import os
from concurrent.futures import ProcessPoolExecutor
from typing import Protocol

import numpy as np

from enn_traffic.errors import InputError
from enn_traffic.scenario import Scenario
from enn_traffic.sim.world import EpisodeResults, NavigationWorld


class Evaluator(Protocol):
    def evaluate(self, population: np.ndarray) -> EpisodeResults: ...

    def close(self) -> None: ...


def make_world(scenario: Scenario) -> NavigationWorld:
    """The world a scenario describes."""
    return NavigationWorld(scenario)


class LocalEvaluator:
    """In-process evaluation; the default, needs no service."""

    def __init__(self, scenario: Scenario):
        self.world = make_world(scenario)

    def evaluate(self, population: np.ndarray) -> EpisodeResults:
        return self.world.evaluate(population)

    def close(self) -> None:
        pass


_worker_world: NavigationWorld | None = None


def _init_worker(scenario: Scenario) -> None:
    global _worker_world
    import numba

    numba.set_num_threads(1)
    _worker_world = make_world(scenario)


def _evaluate_chunk(chunk: np.ndarray) -> EpisodeResults:
    assert _worker_world is not None
    return _worker_world.evaluate(chunk)


class ProcessEvaluator:
    """Population chunks over a pool of worker processes.

    Workers are spawned, not forked: numba's OpenMP threads (and later libsumo) do not survive
    a fork.
    """

    def __init__(self, scenario: Scenario, workers: int | None = None):
        self.workers = workers or os.cpu_count() or 1
        self.pool = ProcessPoolExecutor(
            self.workers,
            mp_context=multiprocessing.get_context("spawn"),
            initializer=_init_worker,
            initargs=(scenario,),
        )

    def evaluate(self, population: np.ndarray) -> EpisodeResults:
        chunks = np.array_split(population, min(self.workers * 4, len(population)))
        parts = list(self.pool.map(_evaluate_chunk, chunks))
        return EpisodeResults(
            fitness=np.concatenate([p.fitness for p in parts]),
            steps=np.concatenate([p.steps for p in parts]),
            outcome=np.concatenate([p.outcome for p in parts]),
        )

    def close(self) -> None:
        self.pool.shutdown()


def make_evaluator(
    scenario: Scenario, executor: str = "local", address: str | None = None
) -> Evaluator:
    """The evaluator named on the command line."""
    if executor == "local":
        return LocalEvaluator(scenario)
    if executor == "process":
        return ProcessEvaluator(scenario)
    if executor == "ray":
        raise InputError("the Ray executor is not available yet (issue 7); use local or process",
                         key="--executor")
    raise InputError(f"unknown executor {executor!r}; use local, process or ray", key="--executor")
