"""Each SUMO start in a process of its own (docs/sumo.md, "One SUMO start, one process").

libsumo keeps state from one SUMO start to the next in a process: a crowd's SSM conflict
counts come out otherwise after another scenario ran (measured: 103 and 91 TTC conflicts in two
50 s spans of the stop-and-go crowd in a fresh process, 20 and 10 after a city closed-loop
evaluation; every collision the same). A start whose result is kept therefore runs in a new
Python process that ends with it, and gives the same result whatever ran before.

The process is a plain ``python -m enn_traffic.traffic.fresh`` that reads the call from its
standard input and writes the result to its standard output (pickled): unlike
multiprocessing's spawn, it never re-runs the caller's ``__main__``, so a script without an
``if __name__ == "__main__"`` guard may call it.
"""

from __future__ import annotations

import functools
import os
import pickle
import signal
import subprocess
import sys
import threading
from collections.abc import Callable, Sequence
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path


class FreshProcessError(RuntimeError):
    """The fresh process ended without a result (killed, or it could not start)."""


# The child imports the same copy of the package as the caller, whatever its sys.path.
_PACKAGE_ROOT = str(Path(__file__).resolve().parents[2])


def end_with_parent(parent: int) -> None:
    """In a child process of ``parent`` (its process id), before it runs: end it when the
    parent ends (Linux), so that no fresh process or pool worker outlives a killed caller.
    A parent already gone (killed while the child started) ends the child at once."""
    if sys.platform.startswith("linux"):
        import ctypes

        ctypes.CDLL(None).prctl(1, signal.SIGTERM)  # PR_SET_PDEATHSIG
    if os.getppid() != parent:
        os._exit(1)


def _run(function: Callable, args: tuple, running: set | None = None,
         cancelled: threading.Event | None = None):
    """``function(*args)`` in a new process; its exception, if any, raised here. The process
    is in ``running`` while it runs, so that the caller can end it; one started after the
    caller set ``cancelled`` ends at once (it may have missed the caller's sweep)."""
    job = pickle.dumps((function, tuple(args)), protocol=pickle.HIGHEST_PROTOCOL)
    path = os.environ.get("PYTHONPATH")
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(filter(None, [_PACKAGE_ROOT, path]))}
    running = set() if running is None else running
    with subprocess.Popen([sys.executable, "-m", __name__], stdin=subprocess.PIPE,
                          stdout=subprocess.PIPE, env=env,
                          preexec_fn=functools.partial(end_with_parent, os.getpid())) as process:
        running.add(process)
        try:
            if cancelled is not None and cancelled.is_set():
                process.kill()
            output, _ = process.communicate(job)
        except BaseException:  # Ctrl-C too: the process ends with the wait for it
            process.kill()
            raise
        finally:
            running.discard(process)
    if process.returncode != 0 or not output:
        raise FreshProcessError(f"{getattr(function, '__qualname__', function)} ended with "
                                f"exit status {process.returncode} in its own process (its "
                                "messages, if any, are above)")
    failed, value = pickle.loads(output)
    if failed:
        raise value
    return value


def fresh_calls(calls: Sequence[tuple], workers: int = 1) -> list:
    """Each call ``(function, *args)`` of ``calls`` in a new process (at most ``workers`` at
    once); the results in order. A ``function`` must be importable by name (a module-level
    function of the package) and its arguments must pickle. Interrupted (Ctrl-C, ``kill
    -INT``), every process still running ends at once."""
    if workers <= 1 or len(calls) <= 1:
        return [_run(call[0], call[1:]) for call in calls]
    running: set[subprocess.Popen] = set()
    cancelled = threading.Event()
    pool = ThreadPoolExecutor(max_workers=min(workers, len(calls)))
    try:
        return list(pool.map(lambda call: _run(call[0], call[1:], running, cancelled), calls))
    except BaseException:
        cancelled.set()  # first: a process started from now on ends by itself
        for process in list(running):  # their threads then return, and the pool closes
            process.kill()
        raise
    finally:
        pool.shutdown(wait=True, cancel_futures=True)


def fresh_map(function: Callable, calls: Sequence[tuple], workers: int = 1) -> list:
    """``function(*args)`` for each ``args`` of ``calls``, each in a new process
    (:func:`fresh_calls`)."""
    return fresh_calls([(function, *args) for args in calls], workers)


def fresh(function: Callable, *args):
    """``function(*args)`` in a new process of its own."""
    return _run(function, args)


def _serve() -> None:
    """The fresh process: one call from standard input, its result to standard output; what
    the call prints (SUMO's console too) goes to standard error."""
    answer = os.fdopen(os.dup(1), "wb")
    os.dup2(2, 1)
    sys.stdout = sys.stderr
    function, args = pickle.loads(sys.stdin.buffer.read())
    try:
        result = (False, function(*args))
    except BaseException as exc:  # handed to the caller, who raises it
        result = (True, exc)
    try:
        data = pickle.dumps(result, protocol=pickle.HIGHEST_PROTOCOL)
    except Exception:  # an exception that does not pickle (libsumo's): its type and message
        from enn_traffic.traffic.fresh import FreshProcessError as Error  # not __main__'s

        exc = result[1] if result[0] else None
        data = pickle.dumps((True, Error(
            f"{type(exc).__name__}: {exc}" if exc else "the result does not pickle")))
    answer.write(data)
    answer.close()


if __name__ == "__main__":
    _serve()
