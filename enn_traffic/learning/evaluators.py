"""Evaluators: how a population's fitness gets computed (docs/design.md, "Scale-out").

The GA calls ``evaluator.evaluate(population, key) -> SituationResults`` and nothing else (the
traffic key picks the traffic situations: a training generation's number, or a held-out key,
:mod:`enn_traffic.core.keys`). ``local`` runs the compiled batch in this process (numba threads over
the cores); ``process`` splits the population into chunks over a process pool, each worker
building its own world once. Results do not depend on the backend or the number of workers.
"""

from __future__ import annotations

import contextlib
import logging
import multiprocessing
import os
import signal
import threading
from concurrent.futures import ProcessPoolExecutor
from dataclasses import replace
from pathlib import Path
from typing import Protocol

import numpy as np

from enn_traffic.config import Scenario
from enn_traffic.core.errors import InputError
from enn_traffic.core.progress import log
from enn_traffic.sim.world import SituationResults, World, make_world
from enn_traffic.sumo.fresh import end_with_parent


class Evaluator(Protocol):
    def evaluate(self, population: np.ndarray, key: int = 0) -> SituationResults: ...

    def close(self) -> None: ...


class LocalEvaluator:
    """In-process evaluation; the default, needs no service."""

    def __init__(self, scenario: Scenario):
        self.world = make_world(scenario)

    def evaluate(self, population: np.ndarray, key: int = 0) -> SituationResults:
        return self.world.evaluate(population, key)

    def close(self) -> None:
        pass


_worker_world: World | None = None


def _single_threaded_world(scenario: Scenario) -> World:
    """A worker's world (and, for SUMO traffic, its libsumo): one core per worker."""
    import numba

    numba.set_num_threads(1)
    return make_world(scenario)


def quiet_worker(parent: int) -> None:
    """A pool worker's start: it ends with its parent, and leaves Ctrl-C to it (Ctrl-C
    reaches the terminal's whole process group: the parent says it and ends the workers; a
    worker that left by itself could break the pool before the parent heard it)."""
    end_with_parent(parent)
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # drops a Ctrl-C held back since the start
    if hasattr(signal, "pthread_sigmask"):
        signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})


def stop_pool(pool: ProcessPoolExecutor) -> None:
    """End a pool's workers now, their work unfinished (on Ctrl-C or SIGTERM)."""
    for process in list((getattr(pool, "_processes", None) or {}).values()):
        process.terminate()
    pool.shutdown(wait=False, cancel_futures=True)


def _init_worker(scenario: Scenario, parent: int) -> None:
    global _worker_world
    quiet_worker(parent)
    _worker_world = _single_threaded_world(scenario)


@contextlib.contextmanager
def sigint_held_back():
    """SIGINT held back while workers are started: they inherit the calling thread's blocked
    signal mask, so a Ctrl-C while one imports prints no traceback (:func:`quiet_worker` then
    ignores SIGINT and unblocks it). The parent's Ctrl-C is delayed, not lost: another thread
    of the parent may take the signal while this one blocks it, so the handler here only
    notes it, and it is raised again as the block ends. (Ignoring SIGINT here instead lost a
    Ctrl-C that came during the block: the run went on.)"""
    if not hasattr(signal, "pthread_sigmask"):  # Windows: no masks, no process group Ctrl-C
        yield
        return
    heard: list[int] = []
    main = threading.current_thread() is threading.main_thread()
    previous = signal.signal(signal.SIGINT, lambda number, frame: heard.append(number)) \
        if main else None
    mask = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, mask)
        if main:
            signal.signal(signal.SIGINT, previous)
            if heard:
                signal.raise_signal(signal.SIGINT)  # to the handler it was meant for


def _evaluate_chunk(chunk: np.ndarray, key: int) -> SituationResults:
    assert _worker_world is not None
    return _worker_world.evaluate(chunk, key)


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
            initargs=(scenario, os.getpid()),
        )

    def evaluate(self, population: np.ndarray, key: int = 0) -> SituationResults:
        chunks = np.array_split(population, min(self.workers * 4, len(population)))
        try:
            with sigint_held_back():  # the pool starts its workers as chunks are submitted
                futures = [self.pool.submit(_evaluate_chunk, chunk, key) for chunk in chunks]
            return SituationResults.concatenate([future.result() for future in futures])
        except BaseException:  # Ctrl-C, SIGTERM: the workers end now, their chunks unfinished
            stop_pool(self.pool)
            raise

    def close(self) -> None:
        self.pool.shutdown()


class _WorldActor:
    """A Ray worker holding its own world."""

    def __init__(self, scenario: Scenario):
        self.world = _single_threaded_world(scenario)

    def evaluate(self, chunk: np.ndarray, key: int) -> SituationResults:
        return self.world.evaluate(chunk, key)


def _check_reachable(address: str, timeout: float = 3.0) -> None:
    """Fail fast on a ``host:port`` nobody listens at (Ray itself retries for minutes)."""
    import socket

    host, _, port = address.rpartition(":")
    try:
        with socket.create_connection((host, int(port)), timeout=timeout):
            pass
    except (OSError, ValueError) as exc:
        raise InputError(f"cannot reach Ray at {address}: {exc}", key="--address") from None


def connect_ray(address: str | None = None):
    """The ``ray`` module, initialised: a local Ray for ``address=None``, else the running
    cluster there (a Ray already initialised in this process is used as it is)."""
    try:
        import ray
    except ImportError:
        raise InputError("the Ray executor needs Ray: pip install -e .[ray]",
                         key="--executor") from None
    if not log.isEnabledFor(logging.INFO):  # --quiet: Ray's start-up notes too
        logging.getLogger("ray").setLevel(logging.ERROR)
    if address and ":" in address and "://" not in address:
        _check_reachable(address)
    if not ray.is_initialized():
        try:
            ray.init(address=address, include_dashboard=False, log_to_driver=False,
                     configure_logging=False, **_short_temp_dir(address))
        except (ConnectionError, RuntimeError, ValueError) as exc:
            raise InputError(f"cannot reach Ray at {address}: {exc}", key="--address") from None
    return ray


RAY_TEMP_ROOM = 40  # characters of a temporary folder's path that Ray's sockets leave room for


def _short_temp_dir(address: str | None) -> dict:
    """A local Ray's session folder where its sockets' paths fit the 107 bytes a Unix socket
    may have: under the temporary folder when its path is short, else ``/tmp/ray-UID``
    (``$RAY_TMPDIR``, when set, is Ray's own choice and stands)."""
    import tempfile

    if address is not None or os.environ.get("RAY_TMPDIR"):
        return {}
    if len(tempfile.gettempdir()) <= RAY_TEMP_ROOM:
        return {}
    short = Path("/tmp") / f"ray-{os.getuid()}"
    try:
        short.mkdir(mode=0o700, exist_ok=True)
    except OSError:
        raise InputError(f"the temporary folder's path ({len(tempfile.gettempdir())} "
                         "characters) is too long for Ray's sockets and /tmp cannot be "
                         "written: set RAY_TMPDIR to a short folder", key="--executor") \
            from None
    return {"_temp_dir": str(short)}


class RayEvaluator:
    """Population chunks over Ray actors, each holding its own world (docs/design.md, "Scale-out").

    ``address=None`` starts a local Ray; otherwise it joins the running cluster there. A
    chromosome's fitness depends only on it and the key's traffic, never on the chunk
    it was in, so results are identical with any number of workers.
    """

    def __init__(self, scenario: Scenario, address: str | None = None,
                 workers: int | None = None):
        self.ray = ray = connect_ray(address)
        self.workers = workers or max(int(ray.cluster_resources().get("CPU", 1)), 1)
        actor = ray.remote(num_cpus=1)(_WorldActor)
        self.actors = [actor.remote(scenario) for _ in range(self.workers)]

    def evaluate(self, population: np.ndarray, key: int = 0) -> SituationResults:
        chunks = np.array_split(population, min(self.workers, len(population)))
        futures = [actor.evaluate.remote(chunk, key)
                   for actor, chunk in zip(self.actors, chunks, strict=False)]
        return SituationResults.concatenate(self.ray.get(futures))

    def close(self) -> None:
        for actor in self.actors:
            self.ray.kill(actor)
        self.actors = []


class MeanOverWorlds:
    """Fitness averaged over the episodes of several worlds, one per traffic strategy:
    incremental evolution (§5.4.1) over strategies that may differ in network and traffic."""

    def __init__(self, worlds: list[World]):
        self.worlds = worlds

    def evaluate(self, population: np.ndarray, key: int = 0) -> SituationResults:
        parts = [world.evaluate(population, key) for world in self.worlds]
        vehicles = round(float(np.mean([p.vehicles for p in parts])))
        return replace(SituationResults.concatenate(parts, axis=1), vehicles=vehicles)

    def close(self) -> None:
        pass


def make_evaluator(
    scenario: Scenario, executor: str = "local", address: str | None = None
) -> Evaluator:
    """The evaluator named on the command line."""
    if executor == "local":
        return LocalEvaluator(scenario)
    if executor == "process":
        return ProcessEvaluator(scenario)
    if executor == "ray":
        return RayEvaluator(scenario, address)
    raise InputError(f"unknown executor {executor!r}; use local, process or ray", key="--executor")
