"""An environment held by a spawned child process, for a second live SUMO in one process
(libsumo runs one SUMO per process; docs/envs.md, "Several learners at once").

The parent calls the child's environment's methods by name and gets back what they return
with the environment's ``agents`` after the call; an exception raised there is raised here.
The child ends with its parent (``PR_SET_PDEATHSIG``) and when the owner is collected.
"""

from __future__ import annotations

import multiprocessing
import os
import weakref
from collections.abc import Callable

from enn_traffic.core.io import sweep_process_folders


def _serve(connection, make: Callable, args: tuple, kwargs: dict, parent: int) -> None:
    import signal

    from enn_traffic.sumo.fresh import end_with_parent

    end_with_parent(parent)
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # the parent hears Ctrl-C and ends us
    env = make(*args, **kwargs)
    try:
        while True:
            try:
                name, call_args, call_kwargs = connection.recv()
            except EOFError:  # the parent closed its end
                return
            try:
                value = getattr(env, name)(*call_args, **call_kwargs)
                connection.send((True, value, list(env.agents)))
            except Exception as exc:  # noqa: BLE001 — raised again in the parent
                connection.send((False, exc, list(env.agents)))
    finally:
        env.close()


class InChild:
    """``make(*args, **kwargs)`` built and held in a spawned child process."""

    def __init__(self, owner: object, make: Callable, args: tuple = (), kwargs: dict | None = None):
        context = multiprocessing.get_context("spawn")  # numba's threads and libsumo
        self._connection, child = context.Pipe()
        self._process = context.Process(
            target=_serve, args=(child, make, args, kwargs or {}, os.getpid()), daemon=True)
        self._process.start()
        child.close()
        weakref.finalize(owner, _end, self._connection, self._process)

    def call(self, name: str, *args, **kwargs) -> tuple[object, list[str]]:
        """The child's ``env.name(*args, **kwargs)`` and its ``agents`` after the call."""
        self._connection.send((name, args, kwargs))
        try:
            ok, value, agents = self._connection.recv()
        except EOFError:
            raise RuntimeError("the environment's child process ended (its SUMO failed or "
                               "was killed)") from None
        if not ok:
            raise value
        return value, agents


def _end(connection, process) -> None:
    connection.close()
    process.join(timeout=10)
    if process.is_alive():
        process.terminate()
    sweep_process_folders(pid=process.pid, wait_s=2.0)  # a SUMO folder it could not remove
