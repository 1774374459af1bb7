"""The ``enn-traffic`` command line (docs/design.md, "Command line"): one module per command
(``add_parser`` and ``run``), listed in :data:`COMMANDS`; here the signals, exit statuses and
messages they share.

Bad input ends with one message naming the file and key, and exit status 2; never a traceback.
"""

from __future__ import annotations

import argparse
import codecs
import errno
import signal
import sys
import threading
import time

from enn_traffic import __version__
from enn_traffic.cli import baseline, bench, crowd, evaluate, lanes, render, reproduce, run
from enn_traffic.cli.args import EPILOG, Parser
from enn_traffic.core import interrupts
from enn_traffic.core.errors import InputError

# The commands in the order ``--help`` lists them: each a module of this package, named as
# the command.
COMMANDS = {module.__name__.rsplit(".", 1)[1]: module
            for module in (run, evaluate, render, reproduce, crowd, lanes, baseline, bench)}


def build_parser() -> argparse.ArgumentParser:
    parser = Parser(
        prog="enn-traffic",
        description="Evolve neural-network driving controllers in SUMO traffic "
        "(Eraqi et al., 2016).",
        epilog=EPILOG,
    )
    parser.add_argument("--version", action="version", version=f"enn-traffic {__version__}")
    commands = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for command in COMMANDS.values():
        command.add_parser(commands)
    return parser


def _interrupted_note(args) -> str:
    """What an interrupted command leaves: a run says whether a generation had finished."""
    if args.command == "run":
        from enn_traffic.runs.run import CHECKPOINT

        folder = getattr(args, "run_folder", None)
        if folder is None or not (folder / CHECKPOINT).exists():
            return "; no generation had finished: nothing to resume"
    return getattr(COMMANDS[args.command], "INTERRUPTED", "")


def _as_given(error: UnicodeEncodeError) -> tuple[str | bytes, int]:
    """What a character the terminal's encoding cannot write becomes: a byte of a path that
    was not text in that encoding (Python keeps it as a lone surrogate) the byte it was, so
    that a printed path pastes back; any other character escaped (``\\u03a9``)."""
    part = error.object[error.start:error.end]
    if all("\udc80" <= character <= "\udcff" for character in part):
        return bytes(ord(character) - 0xDC00 for character in part), error.end
    return codecs.backslashreplace_errors(error)


SHOWN_AS_GIVEN = "enn-traffic-as-given"
codecs.register_error(SHOWN_AS_GIVEN, _as_given)


def main(argv: list[str] | None = None) -> int:
    from enn_traffic.core.progress import show_messages

    for stream in (sys.stdout, sys.stderr):  # a path the terminal's encoding cannot show is
        if hasattr(stream, "reconfigure"):  # escaped, not a crash after the work is done
            stream.reconfigure(errors=SHOWN_AS_GIVEN)
    args = build_parser().parse_args(argv)
    show_messages(quiet=getattr(args, "quiet", False))
    handlers, hook = {}, sys.unraisablehook
    interrupts.reset()
    if threading.current_thread() is threading.main_thread():
        # a job started with & by a script inherits SIGINT ignored: kill -INT must stop it;
        # SIGTERM (kill, a batch system's time limit) stops a command as Ctrl-C does
        handlers = {signal.SIGINT: signal.signal(signal.SIGINT, _interrupt),
                    signal.SIGTERM: signal.signal(signal.SIGTERM, _terminate)}
        sys.unraisablehook = interrupts.unraisable
    try:
        return _run_command(args)
    finally:
        for number, handler in handlers.items():
            signal.signal(number, handler)
        sys.unraisablehook = hook
        interrupts.reset()


class Terminated(KeyboardInterrupt):
    """SIGTERM, met as Ctrl-C is: the command stops where it is and says so."""


def _interrupt(number, frame) -> None:
    interrupts.request(KeyboardInterrupt)


def _terminate(number, frame) -> None:
    interrupts.request(Terminated)


def _run_command(args) -> int:
    started = time.perf_counter()
    try:
        if getattr(args, "address", None) is not None and args.executor != "ray":
            raise InputError("a Ray cluster's address is used with --executor ray only (here "
                             f"--executor {args.executor})", key="--address")
        return COMMANDS[args.command].run(args)
    except InputError as exc:  # one line, whatever SUMO's message spans
        print(f"enn-traffic: error: {' '.join(str(exc).split())}", file=sys.stderr)
        return 2
    except BrokenPipeError:  # output piped into a reader that stopped early (e.g. head)
        sys.stderr.close()
        return 0
    except OSError as exc:  # a file that could not be read or written: a full disk, a lost mount
        if exc.errno not in _FILE_TROUBLE:
            raise
        where = f"{exc.filename}: " if exc.filename else ""
        print(f"enn-traffic: error: {where}{exc.strerror or exc}", file=sys.stderr)
        return 2
    except (KeyboardInterrupt, SystemError) as exc:
        cause = _interrupted(exc)
        if cause is None:
            raise
        stopped = "terminated" if isinstance(cause, Terminated) else "interrupted"
        print(f"\nenn-traffic: {stopped} after {time.perf_counter() - started:.0f} s"
              f"{_interrupted_note(args)}", file=sys.stderr)
        return 143 if isinstance(cause, Terminated) else 130
    except Exception as exc:
        if not _worker_lost(exc):
            raise
        first = str(exc).strip().splitlines()[0][:200] if str(exc).strip() else ""
        print(f"enn-traffic: error: a worker process died ({type(exc).__name__}: {first})"
              f"{_interrupted_note(args)}", file=sys.stderr)
        return 1


_FILE_TROUBLE = {errno.ENOSPC, errno.EDQUOT, errno.EROFS, errno.EACCES, errno.EPERM,
                 errno.EFBIG, errno.EIO, errno.ENOENT, errno.ENOTDIR, errno.EISDIR, errno.ELOOP,
                 errno.ENAMETOOLONG}


# What a pool or a Ray cluster raises when a worker process dies under it (killed, out of
# memory): known by name, so that the check needs no Ray installed.
LOST_WORKERS = {("concurrent.futures.process", "BrokenProcessPool"),
                ("ray.exceptions", "ActorDiedError"), ("ray.exceptions", "RayActorError"),
                ("ray.exceptions", "WorkerCrashedError"),
                ("ray.exceptions", "ActorUnavailableError")}


def _worker_lost(exc: BaseException) -> bool:
    """Is ``exc`` (or one of its types' bases) a worker process dying under a pool or Ray?"""
    return any((kind.__module__, kind.__name__) in LOST_WORKERS for kind in type(exc).__mro__)


def _interrupted(exc: BaseException | None) -> KeyboardInterrupt | None:
    """The Ctrl-C (or SIGTERM) behind ``exc``, if any. (One that lands inside a compiled
    kernel comes out of numba as a SystemError caused by it.)"""
    while exc is not None:
        if isinstance(exc, KeyboardInterrupt):
            return exc
        exc = exc.__cause__ or exc.__context__
    return None


if __name__ == "__main__":
    sys.exit(main())
