"""``enn-traffic reproduce``: every experiment of the paper into one folder."""

from __future__ import annotations

from pathlib import Path

from enn_traffic.cli.args import EPILOG, nonempty_path
from enn_traffic.core.errors import InputError

# What an interrupted reproduce leaves.
INTERRUPTED = ("; finished runs and experiments are kept: the same command "
               "continues")


def add_parser(commands) -> None:
    """The command's arguments."""
    command = commands.add_parser("reproduce", help="run the paper's experiments",
                                  epilog=EPILOG)
    command.add_argument("--out", metavar="DIR", type=nonempty_path, default=Path("results/paper"))
    command.add_argument("--quick", action="store_true",
                         help="small populations and few generations (minutes)")
    command.add_argument("--only", metavar="NAME,...",
                         help="comma-separated experiment names (default: all)")
    command.add_argument("--executor", choices=["local", "ray"], default="local",
                         help="where independent whole runs go: one after another here "
                              "(default) or side by side as Ray tasks")
    command.add_argument("--address", metavar="ADDR",
                         help="Ray cluster address (with --executor ray; "
                              "default: start a local Ray)")
    command.add_argument("--quiet", action="store_true", help="no progress bars or messages")


def run(args) -> int:
    from enn_traffic.core.io import check_output_folder
    from enn_traffic.experiments.reproduce import reproduce

    check_output_folder(args.out)
    names = None
    if args.only is not None:
        names = [n.strip() for n in args.only.split(",") if n.strip()]
        if not names:
            raise InputError(f"names no experiment: {args.only!r}", key="--only")
    reproduce(args.out, quick=args.quick, only=names, progress=not args.quiet,
              executor=args.executor, address=args.address)
    return 0
