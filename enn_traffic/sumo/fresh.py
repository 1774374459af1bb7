"""Each SUMO start in a process of its own (docs/sumo.md, "One SUMO start, one process").

libsumo keeps state from one SUMO start to the next in a process: a crowd's SSM conflict
counts come out otherwise after another scenario ran (measured: 103 and 91 TTC conflicts in two
50 s spans of the stop-and-go crowd in a fresh process, 20 and 10 after a city closed-loop
evaluation; every collision the same). A start whose result is kept therefore runs in a new
process that ends with it, and gives the same result whatever ran before.

The new processes are forked from a *zygote*: a plain ``python -m enn_traffic.sumo.fresh``
started once per calling process (again when the caller's environment or working folder
changed), which imports the package's SUMO modules and numba but never starts SUMO, and forks
a child per call. A child so starts with a libsumo that never ran, without the imports and
numba's set-up a new interpreter spends most of its time on (docs/bench.md, "A fresh process
in a fraction of a second"). The call and its result travel
pickled through a socket of the child's own; unlike multiprocessing's spawn or forkserver, the
child never re-runs the caller's ``__main__``, so a script without an ``if __name__ ==
"__main__"`` guard may call it.
"""

from __future__ import annotations

import contextlib
import os
import pickle
import signal
import socket
import struct
import subprocess
import sys
import threading
import traceback
from collections.abc import Callable, Sequence
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

from enn_traffic.core.io import sweep_process_folders


class FreshProcessError(RuntimeError):
    """The fresh process ended without a result (killed, or it could not start)."""


# The zygote imports the same copy of the package as the caller, whatever its sys.path.
_PACKAGE_ROOT = str(Path(__file__).resolve().parents[2])
_NUMBER = struct.Struct("!q")


def child_environment() -> dict[str, str]:
    """The caller's environment with this copy of the package first on ``PYTHONPATH``: what a
    process started for the caller runs with."""
    path = os.environ.get("PYTHONPATH")
    return {**os.environ, "PYTHONPATH": os.pathsep.join(filter(None, [_PACKAGE_ROOT, path]))}


def end_with_parent(parent: int) -> None:
    """In a child process of ``parent`` (its process id), before it runs: end it when the
    parent ends (Linux), so that no fresh process or pool worker outlives a killed caller.
    A parent already gone (killed while the child started) ends the child at once."""
    if sys.platform.startswith("linux"):
        import ctypes

        ctypes.CDLL(None).prctl(1, signal.SIGTERM)  # PR_SET_PDEATHSIG
    if os.getppid() != parent:
        os._exit(1)


def _receive_all(connection: socket.socket) -> bytes:
    """Everything ``connection`` sends until it closes."""
    chunks = []
    while chunk := connection.recv(1 << 20):
        chunks.append(chunk)
    return b"".join(chunks)


def _receive_number(connection: socket.socket) -> int:
    """One number of the zygote's protocol; FreshProcessError if the zygote is gone."""
    data = b""
    while len(data) < _NUMBER.size:
        chunk = connection.recv(_NUMBER.size - len(data))
        if not chunk:
            raise FreshProcessError("the process that starts fresh processes ended")
        data += chunk
    return _NUMBER.unpack(data)[0]


# Variables no child reads that change under a caller running: pytest rewrites this one at
# every phase of every test, which restarted the zygote (its start: docs/bench.md) before
# each test that starts a fresh process.
UNREAD_VARIABLES = ("PYTEST_CURRENT_TEST",)


def _environment() -> dict[str, str]:
    """The caller's environment as far as a fresh process depends on it."""
    return {name: value for name, value in os.environ.items() if name not in UNREAD_VARIABLES}


class _Zygote:
    """The caller's side of a zygote: start a child for a call, end it, read how it ended."""

    def __init__(self) -> None:
        self.owner, self.environment, self.folder = os.getpid(), _environment(), os.getcwd()
        ours, theirs = socket.socketpair()
        self.process = subprocess.Popen(
            [sys.executable, "-m", __name__, str(theirs.fileno())], pass_fds=[theirs.fileno()],
            stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, env=child_environment())
        theirs.close()
        self.control, self.lock = ours, threading.Lock()

    def fits(self) -> bool:
        """Whether this zygote forks what a new process of the caller would start now."""
        return (self.owner == os.getpid() and self.process.poll() is None
                and self.environment == _environment() and self.folder == os.getcwd())

    def start(self, job: bytes) -> tuple[int, socket.socket]:
        """A child running ``job``: its process id and the socket its result comes from."""
        ours, theirs = socket.socketpair()
        try:
            with self.lock:
                socket.send_fds(self.control, [b"R"], [theirs.fileno()])
                pid = _receive_number(self.control)
        finally:
            theirs.close()
        ours.sendall(job)
        ours.shutdown(socket.SHUT_WR)
        return pid, ours

    def ask(self, request: bytes, pid: int) -> int:
        """Kill (``b"K"``) child ``pid`` or wait for (``b"W"``) its exit status."""
        with self.lock:
            self.control.sendall(request + _NUMBER.pack(pid))
            return _receive_number(self.control)

    def close(self) -> None:
        self.control.close()  # the zygote ends its children and itself
        try:
            self.process.wait(timeout=10)
        except subprocess.TimeoutExpired:
            self.process.kill()


_zygote: _Zygote | None = None
_zygote_lock = threading.Lock()


def _current_zygote() -> _Zygote:
    """The zygote for this process's calls, started (again) when none fits."""
    global _zygote
    with _zygote_lock:
        if _zygote is None or not _zygote.fits():
            if _zygote is not None and _zygote.owner == os.getpid():
                _zygote.close()
            _zygote = _Zygote()
        return _zygote


class _Child:
    """A running fresh process, as the caller's sweep ends it."""

    def __init__(self, zygote: _Zygote, pid: int) -> None:
        self.zygote, self.pid = zygote, pid

    def kill(self) -> None:
        with contextlib.suppress(OSError, FreshProcessError):  # else the zygote, and so
            self.zygote.ask(b"K", self.pid)  # the child, is gone
        sweep_process_folders(pid=self.pid, wait_s=2.0)  # the SUMO folder it could not remove


def _run(function: Callable, args: tuple, running: set | None = None,
         cancelled: threading.Event | None = None):
    """``function(*args)`` in a new process; its exception, if any, raised here. The process
    is in ``running`` while it runs, so that the caller can end it; one started after the
    caller set ``cancelled`` ends at once (it may have missed the caller's sweep)."""
    job = pickle.dumps((function, tuple(args)), protocol=pickle.HIGHEST_PROTOCOL)
    zygote = _current_zygote()
    pid, connection = zygote.start(job)
    child = _Child(zygote, pid)
    running = set() if running is None else running
    running.add(child)
    try:
        with connection:
            if cancelled is not None and cancelled.is_set():
                child.kill()
            output = _receive_all(connection)
    except BaseException:  # Ctrl-C too: the process ends with the wait for it
        child.kill()
        raise
    finally:
        running.discard(child)
    if not output:
        status = zygote.ask(b"W", pid)
        raise FreshProcessError(f"{getattr(function, '__qualname__', function)} ended with "
                                f"exit status {status} in its own process (its messages, if "
                                "any, are above)")
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
    running: set[_Child] = set()
    cancelled = threading.Event()
    pool = ThreadPoolExecutor(max_workers=min(workers, len(calls)))
    try:
        return list(pool.map(lambda call: _run(call[0], call[1:], running, cancelled), calls))
    except BaseException:
        cancelled.set()  # first: a process started from now on ends by itself
        for child in list(running):  # their threads then return, and the pool closes
            child.kill()
        raise
    finally:
        pool.shutdown(wait=True, cancel_futures=True)


def fresh_map(function: Callable, calls: Sequence[tuple], workers: int = 1) -> list:
    """``function(*args)`` for each ``args`` of ``calls``, each in a new process
    (:func:`fresh_calls`)."""
    return fresh_calls([(function, *args) for args in calls], workers)


# How many fresh processes the package's callers run at once (SUMO recordings and closed-loop
# situations, lane keeping's test roads, Table 3's ranking).
WORKERS = max(1, min(4, os.cpu_count() or 1))


def fresh_shares(function: Callable, items: Sequence, *args, workers: int = WORKERS) -> list:
    """``function(*args, share)`` for ``workers`` shares of ``items`` (every ``workers``-th
    item from the first, the second, ...), each in a new process (:func:`fresh_calls`);
    ``function`` returns one result per item of its share, and these come back in the order
    of ``items``."""
    shares = [items[i::workers] for i in range(workers)]
    done = fresh_map(function, [(*args, share) for share in shares if len(share)], workers)
    results: list = [None] * len(items)
    for i, share in enumerate(done):
        results[i::workers] = share
    return results


def fresh(function: Callable, *args):
    """``function(*args)`` in a new process of its own."""
    return _run(function, args)


def _serve(connection: socket.socket) -> None:
    """A forked child: one call from ``connection``, its result back; what the call prints
    (SUMO's console too) goes to standard error."""
    os.dup2(2, 1)
    sys.stdout = sys.stderr
    function, args = pickle.loads(_receive_all(connection))
    try:
        result = (False, function(*args))
    except BaseException as exc:  # handed to the caller, who raises it
        result = (True, exc)
    try:
        data = pickle.dumps(result, protocol=pickle.HIGHEST_PROTOCOL)
    except Exception:  # an exception that does not pickle (libsumo's): its type and message
        from enn_traffic.sumo.fresh import FreshProcessError as Error  # not __main__'s

        exc = result[1] if result[0] else None
        data = pickle.dumps((True, Error(
            f"{type(exc).__name__}: {exc}" if exc else "the result does not pickle")))
    connection.sendall(data)
    connection.close()


def _zygote_main(control: socket.socket) -> None:
    """The zygote: preload, then fork a child per request of the caller (``R``, with the
    child's socket), end one (``K``) or report how one ended (``W``); end every child and
    itself when the caller's side closes."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C reaches the caller and the children
    _preload()
    me, live, ended = os.getpid(), set(), {}
    while True:
        message, fds, _, _ = socket.recv_fds(control, 1, 1)
        if message[:1] in (b"K", b"W"):
            message += control.recv(_NUMBER.size, socket.MSG_WAITALL)
            if len(message) != 1 + _NUMBER.size:
                message = b""  # the caller closed its side mid-message
        for pid in list(live):  # reap: a pid in ``live`` is never another process's
            done, status = os.waitpid(pid, os.WNOHANG)
            if done:
                live.discard(pid)
                ended[pid] = os.waitstatus_to_exitcode(status)
                if len(ended) > 1024:  # the oldest, never asked for
                    ended.pop(next(iter(ended)))
        if not message:
            for pid in live:
                os.kill(pid, signal.SIGKILL)
            os._exit(0)
        if message[:1] == b"R":
            pid = os.fork()
            if pid == 0:
                control.close()
                end_with_parent(me)
                signal.signal(signal.SIGINT, signal.default_int_handler)
                code = 1
                try:
                    _serve(socket.socket(fileno=fds[0]))
                    code = 0
                except (KeyboardInterrupt, BrokenPipeError, ConnectionResetError, EOFError):
                    pass  # the caller was interrupted, or is gone: it reads nothing, says why
                except BaseException:  # the caller reads no result: say why here
                    traceback.print_exc()
                finally:
                    os._exit(code)
            os.close(fds[0])
            live.add(pid)
            control.sendall(_NUMBER.pack(pid))
            continue
        for fd in fds:
            os.close(fd)
        pid = _NUMBER.unpack(message[1:])[0]
        if message[:1] == b"K":
            if pid in live:
                os.kill(pid, signal.SIGKILL)
            control.sendall(_NUMBER.pack(0))
        else:  # b"W": the child closed its socket, so it ends now
            if pid in live:
                live.discard(pid)
                ended[pid] = os.waitstatus_to_exitcode(os.waitpid(pid, 0)[1])
            control.sendall(_NUMBER.pack(ended.pop(pid, -1)))


def _preload() -> None:
    """What a SUMO start needs, imported (SUMO itself never started), and numba's compiler set
    up (its registries), so that a child only loads its kernels from the cache.
    Whatever fails here, the child meets again and reports."""
    with contextlib.suppress(Exception):
        import numba

        import enn_traffic.sumo  # noqa: F401  (libsumo, the scenario, the roads)

        numba.njit(lambda: 0)()


if __name__ == "__main__":
    _zygote_main(socket.socket(fileno=int(sys.argv[1])))
