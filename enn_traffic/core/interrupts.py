"""A Ctrl-C or SIGTERM, kept until the command ends.

The command's signal handlers (``enn_traffic.cli``) raise the stop where the main thread is
and record it here; a long loop looks here between its steps (:func:`raise_if_requested`), so
that it stops even when Python swallowed that exception on the way (one raised inside a
finaliser is printed and dropped, and the loop would go on).
"""

from __future__ import annotations

import sys

_requested: type[KeyboardInterrupt] | None = None


def request(stop: type[KeyboardInterrupt]) -> None:
    """Record ``stop`` (KeyboardInterrupt or a subclass) and raise it; after a first stop,
    raise that one again (a SIGTERM then a Ctrl-C: the command says "terminated")."""
    global _requested
    if _requested is None:
        _requested = stop
    raise _requested


def raise_if_requested() -> None:
    """Raise the stop recorded since :func:`reset`, if any."""
    if _requested is not None:
        raise _requested


def reset() -> None:
    """Forget a recorded stop (a command's start and end)."""
    global _requested
    _requested = None


def unraisable(info) -> None:
    """``sys.unraisablehook`` while a command runs: a stop swallowed in a finaliser says
    nothing (the loop raises it again); anything else as Python reports it."""
    if _requested is not None and issubclass(info.exc_type, KeyboardInterrupt):
        return
    sys.__unraisablehook__(info)
