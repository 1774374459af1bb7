"""Messages about slow steps, so that no command waits in silence.

A step wrapped in :func:`slow_step` says what it is doing once it has taken a second, and how
long it took when it ends; quick steps say nothing. Messages go to the ``enn_traffic`` logger,
which the command line prints to standard error (``--quiet`` silences it); a program that
configured no logging at all (a script, a notebook using the environments) gets them on
standard error too.
"""

from __future__ import annotations

import contextlib
import ctypes
import io
import logging
import os
import sys
import threading
import time
from collections.abc import Iterator
from pathlib import Path
from typing import TextIO

from tqdm import tqdm

log = logging.getLogger("enn_traffic")
SLOW_S = 1.0


_depth = threading.local()  # slow steps running in this thread


@contextlib.contextmanager
def slow_step(what: str, after_s: float = SLOW_S) -> Iterator[None]:
    """Say ``what`` is being done once it has taken ``after_s`` seconds, and how long it took
    when done (or after how long it stopped, on an error). A slow step inside another says
    nothing: the outer one names the wait."""
    depth = getattr(_depth, "value", 0)
    if depth:
        _depth.value = depth + 1
        try:
            yield
        finally:
            _depth.value = depth
        return
    started = time.perf_counter()
    said = threading.Event()

    def say() -> None:
        said.set()
        _tell(f"{what} ...")

    timer = threading.Timer(after_s, say)
    timer.daemon = True
    timer.start()
    _depth.value = 1
    try:
        yield
    except BaseException:  # "done" only when done
        timer.cancel()
        if said.is_set():
            _tell(f"{what}: stopped after {time.perf_counter() - started:.1f} s")
        raise
    finally:
        _depth.value = 0
    timer.cancel()
    if said.is_set():
        _tell(f"{what}: done in {time.perf_counter() - started:.1f} s")


def showing() -> bool:
    """Whether messages and progress bars are shown (not with ``--quiet``)."""
    if log.handlers or logging.getLogger().handlers:
        return log.isEnabledFor(logging.INFO)
    return True


def bar(total: float, what: str, unit: str, **options) -> tqdm:
    """A progress bar for a wait of ``total`` ``unit``s (SUMO seconds, vehicles, lanes ...),
    drawn on the terminal once it has lasted :data:`SLOW_S` and not at all when messages are
    off; it leaves its last state on the screen."""
    return tqdm(total=total, desc=f"enn-traffic: {what}", unit=unit, delay=SLOW_S,
                file=terminal(), disable=not showing(), dynamic_ncols=True, **options)


_redirected: TextIO | None = None  # the terminal while standard error goes elsewhere
_switch = threading.RLock()  # held while output changes place, and by every message's write
_C = ctypes.CDLL(None)


@contextlib.contextmanager
def console_into(path: Path) -> Iterator[None]:
    """The process's standard output and error into ``path`` while inside (SUMO's console,
    which libsumo prints from C), while enn-traffic's own messages and bars go on to the
    terminal: the log holds SUMO's output only."""
    global _redirected
    with _switch:  # no message is half-written while the descriptors move
        for stream in (sys.stdout, sys.stderr):
            if stream is not None:
                stream.flush()
        saved = os.dup(1), os.dup(2)
        target = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_APPEND, 0o644)
        os.dup2(target, 1)
        os.dup2(target, 2)
        _redirected = os.fdopen(os.dup(saved[1]), "w", buffering=1)
    try:
        yield
    finally:
        with _switch:
            _C.fflush(None)
            os.dup2(saved[0], 1)
            os.dup2(saved[1], 2)
            for handle in (*saved, target):
                os.close(handle)
            _redirected.close()
            _redirected = None


class _Terminal(io.TextIOBase):
    """Standard error as the user sees it: ``sys.stderr``, or the terminal's copy while SUMO's
    console is redirected (looked up at every write, so a bar made before a redirection
    does not draw into SUMO's log)."""

    @staticmethod
    def _stream() -> TextIO:
        return _redirected if _redirected is not None else sys.stderr

    def write(self, text: str) -> int:
        with _switch:  # written whole where the terminal is now, nothing left in a buffer
            stream = self._stream()
            written = stream.write(text)
            stream.flush()
            return written

    def flush(self) -> None:
        with _switch:
            self._stream().flush()

    def fileno(self) -> int:
        with _switch:
            return self._stream().fileno()

    def isatty(self) -> bool:
        return self._stream().isatty()

    @property
    def encoding(self) -> str:
        return getattr(self._stream(), "encoding", None) or "utf-8"


_TERMINAL = _Terminal()


def terminal() -> TextIO:
    """Where messages and progress bars go (:class:`_Terminal`)."""
    return _TERMINAL


def _tell(message: str) -> None:
    """``message`` to the ``enn_traffic`` logger, or to standard error when no logging is
    configured anywhere (Python would drop an INFO message then)."""
    if log.handlers or logging.getLogger().handlers:
        log.info(message)
    else:
        print(f"enn-traffic: {message}", file=terminal(), flush=True)


class _AboveBars(logging.Handler):
    """Writes a message above any progress bar on standard error (tqdm redraws the bar)."""

    def emit(self, record: logging.LogRecord) -> None:
        tqdm.write(self.format(record), file=terminal())


def show_messages(quiet: bool) -> None:
    """Print the ``enn_traffic`` messages to standard error (none with ``quiet``)."""
    if not log.handlers:
        handler = _AboveBars()
        handler.setFormatter(logging.Formatter("enn-traffic: %(message)s"))
        log.addHandler(handler)
    log.setLevel(logging.WARNING if quiet else logging.INFO)
    log.propagate = False
