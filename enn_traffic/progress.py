"""Messages about slow steps, so that no command waits in silence.

A step wrapped in :func:`slow_step` says what it is doing once it has taken a second, and how
long it took when it ends; quick steps say nothing. Messages go to the ``enn_traffic`` logger,
which the command line prints to standard error (``--quiet`` silences it); a program that
configured no logging at all (a script, a notebook using the environments) gets them on
standard error too.
"""

from __future__ import annotations

import contextlib
import logging
import sys
import threading
import time
from collections.abc import Iterator

from tqdm import tqdm

log = logging.getLogger("enn_traffic")
SLOW_S = 1.0


@contextlib.contextmanager
def slow_step(what: str, after_s: float = SLOW_S) -> Iterator[None]:
    """Say ``what`` is being done once it has taken ``after_s`` seconds, and how long it took
    when done."""
    started = time.perf_counter()
    said = threading.Event()

    def say() -> None:
        said.set()
        _tell(f"{what} ...")

    timer = threading.Timer(after_s, say)
    timer.daemon = True
    timer.start()
    try:
        yield
    finally:
        timer.cancel()
        if said.is_set():
            _tell(f"{what}: done in {time.perf_counter() - started:.1f} s")


def _tell(message: str) -> None:
    """``message`` to the ``enn_traffic`` logger, or to standard error when no logging is
    configured anywhere (Python would drop an INFO message then)."""
    if log.handlers or logging.getLogger().handlers:
        log.info(message)
    else:
        print(f"enn-traffic: {message}", file=sys.stderr, flush=True)


class _AboveBars(logging.Handler):
    """Writes a message above any progress bar on standard error (tqdm redraws the bar)."""

    def emit(self, record: logging.LogRecord) -> None:
        tqdm.write(self.format(record), file=sys.stderr)


def show_messages(quiet: bool) -> None:
    """Print the ``enn_traffic`` messages to standard error (none with ``quiet``)."""
    if not log.handlers:
        handler = _AboveBars()
        handler.setFormatter(logging.Formatter("enn-traffic: %(message)s"))
        log.addHandler(handler)
    log.setLevel(logging.WARNING if quiet else logging.INFO)
    log.propagate = False
