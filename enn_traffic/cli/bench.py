"""``enn-traffic bench``: the throughput and timing table."""

from __future__ import annotations

from enn_traffic.bench import CHECKOUT, LONG, WORKLOADS
from enn_traffic.cli.args import nonempty_path
from enn_traffic.core.errors import InputError


def add_parser(commands) -> None:
    """The command's arguments; the workloads named from :data:`enn_traffic.bench.WORKLOADS`
    (which imports none of them)."""
    long = [name for name in WORKLOADS if name in LONG and name not in CHECKOUT]
    listed = [f"{name} ({CHECKOUT[name]}: only when named)" if name in CHECKOUT else name
              for name in WORKLOADS]
    command = commands.add_parser("bench", help="throughput and timing table (steps per second, "
                                  "seconds)")
    command.add_argument("--quick", action="store_true",
                         help="about a minute: shorter timings on smaller inputs, whose "
                         "rates are not comparable with the full bench's; without "
                         f"{', '.join(long[:-1])} and {long[-1]} (minutes each, with or without "
                         "--quick) unless --only names them")
    command.add_argument("--out", type=nonempty_path, metavar="FILE.csv",
                         help="also write the table")
    command.add_argument("--only", metavar="NAME,...",
                         help="comma-separated workloads (default: all): "
                         + ", ".join(listed))


def run(args) -> int:
    from enn_traffic.bench import run_bench, table_text, workloads
    from enn_traffic.core.io import check_output_file, write_csv

    if args.out:
        check_output_file(args.out, suffixes=(".csv",))
    only = None
    if args.only is not None:
        only = [n.strip() for n in args.only.split(",") if n.strip()]
        unknown = sorted(set(only) - set(workloads()))
        if not only or unknown:
            raise InputError(f"names no workload: {', '.join(unknown) or repr(args.only)} "
                             f"(workloads: {', '.join(workloads())})", key="--only")
    table = run_bench(quick=args.quick, only=only)
    print(table_text(table))
    if args.out:
        write_csv(args.out, table)
    return 0
