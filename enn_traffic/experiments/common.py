"""Helpers the experiments share: saved controllers, and whole runs reused, resumed or done,
here or on Ray."""

from __future__ import annotations

import os
import tempfile
from collections.abc import Callable, Hashable
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np
import pandas as pd
from tqdm import tqdm

from enn_traffic.config import Scenario
from enn_traffic.core.errors import InputError
from enn_traffic.core.io import write_atomic
from enn_traffic.core.progress import terminal
from enn_traffic.learning.evaluators import connect_ray
from enn_traffic.runs.controller import Controller
from enn_traffic.runs.run import CHECKPOINT, evolve


def save_controller(out: Path, name: str, scenario: Scenario, chromosome: np.ndarray,
                    fitness: float) -> Path:
    """A controller behind a table as ``out/controllers/NAME.npz``, for ``enn-traffic
    evaluate``; ``fitness``: the figure it is known by (its table entry where the table has
    one, else its run's best training fitness; NaN for Table 3's winner, chosen by lives
    lost). Generation -1: it was chosen among a run's candidates, not read from one
    generation."""
    path = out / "controllers" / f"{name}.npz"
    path.parent.mkdir(parents=True, exist_ok=True)
    Controller.from_scenario(scenario, chromosome, fitness, generation=-1).save(path)
    return path


def save_arrays(out: Path, name: str, **arrays: np.ndarray) -> Path:
    """What a table's learners started from besides the controllers (an evolved population,
    what validation showed of each candidate) as ``out/controllers/NAME.npz``: with them, a
    committed table's learning can be driven again."""
    path = out / "controllers" / f"{name}.npz"
    path.parent.mkdir(parents=True, exist_ok=True)
    write_atomic(path, lambda handle: np.savez(handle, **arrays), binary=True)
    return path


def distinct(rows: np.ndarray) -> np.ndarray:
    """The rows of ``rows`` without repeats, in the order they first occur."""
    _, first = np.unique(rows, axis=0, return_index=True)
    return rows[np.sort(first)]


def run_or_reuse(scenario: Scenario, out: Path, progress: bool, **options) -> pd.DataFrame:
    """Evolve into ``out``; a finished run there with the same settings, made by the same code,
    is reused and an interrupted one resumed; any other is run again, and said so."""
    try:
        return evolve(scenario, out, resume=True, progress=progress, **options)
    except InputError as error:
        tqdm.write(f"{out}: {error.message.split(';')[0]}: running it again")
        return evolve(scenario, out, force=True, progress=progress, **options)


Jobs = dict[Hashable, tuple[Scenario, Path]]


class LocalRuns:
    """Whole runs one after another in this process (each uses every core)."""

    def map(self, jobs: Jobs, progress: bool) -> dict[Hashable, pd.DataFrame]:
        return {key: run_or_reuse(sc, out, progress) for key, (sc, out) in jobs.items()}


def _run_in_folder_files(scenario: Scenario, files: dict[str, bytes]
                         ) -> tuple[pd.DataFrame, dict[str, bytes]]:
    """A Ray task: continue the run whose folder held ``files`` in a scratch folder of this
    worker, one core, and send the folder back (no file system shared with the driver)."""
    import numba

    numba.set_num_threads(1)
    with tempfile.TemporaryDirectory() as scratch:
        folder = Path(scratch)
        for name, data in files.items():
            (folder / name).write_bytes(data)
        table = run_or_reuse(scenario, folder, progress=False)
        return table, {path.name: path.read_bytes() for path in folder.iterdir()
                       if path.is_file()}


class RayRuns:
    """Whole runs as Ray tasks, one core each (docs/design.md, "Scale-out"). A run's folder
    travels to the task and back, so an interrupted run resumes there and workers need no
    shared disk; a run's result depends on its scenario only, never on where it ran."""

    def __init__(self, address: str | None = None):
        self.ray = connect_ray(address)
        self.task = self.ray.remote(num_cpus=1)(_run_in_folder_files)

    def map(self, jobs: Jobs, progress: bool) -> dict[Hashable, pd.DataFrame]:
        pending = {}
        for key, (sc, out) in jobs.items():
            files = ({path.name: path.read_bytes() for path in out.iterdir() if path.is_file()}
                     if out.is_dir() else {})
            pending[self.task.remote(sc, files)] = key
        tables = {}
        with tqdm(file=terminal(),
                  total=len(pending), desc="runs on Ray", unit="run", disable=not progress,
                  leave=False) as bar:
            while pending:
                [done], _ = self.ray.wait(list(pending))
                key = pending.pop(done)
                tables[key], files = self.ray.get(done)
                out = jobs[key][1]
                # the checkpoint last: a crash in between leaves a run that resumes cleanly
                for name in sorted(files, key=lambda name: name == CHECKPOINT):
                    write_atomic(out / name, lambda handle, data=files[name]: handle.write(data),
                                 binary=True)
                bar.update(1)
        return {key: tables[key] for key in jobs}


def executor(name: str = "local", address: str | None = None) -> LocalRuns | RayRuns:
    """Where a study's independent whole runs go: ``local`` (one after another) or ``ray``
    (at ``address``, or a local Ray)."""
    if name not in ("local", "ray"):
        raise InputError(f"unknown executor {name!r} for whole runs; use local or ray",
                         key="--executor")
    return RayRuns(address) if name == "ray" else LocalRuns()


def first_generation(table: pd.DataFrame, threshold: float) -> float:
    """The first generation whose best fitness reaches ``threshold`` (NaN if none)."""
    hits = table.loc[table["best_fitness"] >= threshold, "generation"]
    return float(hits.iloc[0]) if len(hits) else float("nan")


def over_situations(rows_of: Callable[..., list[dict]], count: int, settings: object,
                    desc: str, progress: bool) -> pd.DataFrame:
    """``rows_of(situation, settings)`` for situations 0..count-1, every core at once (each
    situation is independent and draws from its own keys, so the rows are the same on any
    number of workers), in situation order, as one table."""
    workers = min(count, os.cpu_count() or 1)
    with ProcessPoolExecutor(workers) if workers > 1 else _InProcess() as pool:
        done = pool.map(rows_of, range(count), [settings] * count)
        return pd.DataFrame([row for rows in tqdm(done, total=count, desc=desc,
                                                  unit="situation", disable=not progress,
                                                  file=terminal())
                             for row in rows])


class _InProcess:
    """:class:`ProcessPoolExecutor`'s ``map`` in this process (one situation or one core)."""

    def __enter__(self) -> _InProcess:
        return self

    def __exit__(self, *exc) -> None:
        return None

    map = staticmethod(map)
