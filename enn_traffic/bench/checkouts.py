"""What a change bought: bench ``crowd_marginal``'s measurement
(:func:`~enn_traffic.bench.marginal.marginal_seconds`: learners in one warmed-up city SUMO, the
step's time by part) run in two checkouts of the project, one fresh interpreter per run, the
checkouts interleaved over the rounds so that both meet the same machine. Each checkout keeps
its own cache folder (numba's kernels, SUMO's warm-ups).

    python -m enn_traffic.bench.checkouts BEFORE AFTER --out results/bench/NAME.csv

One row per run: the checkout's label and commit, the round, the learners, and what
``marginal_seconds`` returns; docs/bench.md turns the rows into the cost per learner and step
(the run of one learner taken off), by part."""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import pandas as pd

# One run, in the checkout's own interpreter: the random city with actuated lights of the
# crowd_marginal rows, the learners driving random networks, with their SSM devices.
_RUN = """
import json, sys
from enn_traffic.bench.measure import city_with_lights
from enn_traffic.bench.marginal import marginal_seconds
net, trips = city_with_lights(int(sys.argv[3]), 0.5)
print(json.dumps(marginal_seconds(net, trips, 0, int(sys.argv[1]), int(sys.argv[2]))))
"""


def commit_of(checkout: Path) -> str:
    """The checkout's commit (12 hex digits) and whether its tree holds changes."""
    run = subprocess.run(["git", "-C", str(checkout), "rev-parse", "--short=12", "HEAD"],
                         capture_output=True, text=True, check=True)
    dirty = subprocess.run(["git", "-C", str(checkout), "status", "--porcelain",
                            "--untracked-files=no"], capture_output=True, text=True, check=True)
    return run.stdout.strip() + ("+changes" if dirty.stdout.strip() else "")


def run_in(checkout: Path, learners: int, steps: int, city: int, cache: Path | None) -> dict:
    """One measurement in ``checkout``'s code, in an interpreter of its own (its cache folder
    ``cache``; None: this process's)."""
    env = os.environ | {"PYTHONPATH": str(checkout)} | (
        {"ENN_TRAFFIC_CACHE": str(cache)} if cache else {})
    done = subprocess.run([sys.executable, "-c", _RUN, str(learners), str(steps), str(city)],
                          cwd=checkout, env=env, capture_output=True, text=True)
    if done.returncode:
        raise RuntimeError(f"{checkout}: the run failed:\n{done.stderr[-2000:]}")
    return json.loads(done.stdout.strip().splitlines()[-1])


def compare(checkouts: dict[str, Path], learners: int, steps: int, rounds: int,
            caches: Path | None, city: int = 1500) -> pd.DataFrame:
    """Every checkout with 1 and with ``learners`` learners, ``rounds`` times, interleaved, on
    the random city of ``city`` junctions; each checkout's cache folder in ``caches`` (None:
    this process's, for checkouts of the same code)."""
    commits = {label: commit_of(path) for label, path in checkouts.items()}
    rows = []
    for round_ in range(rounds):
        for label, path in checkouts.items():
            for count in (learners, 1):
                measured = run_in(path, count, steps, city,
                                  caches / label if caches else None)
                rows.append({"checkout": label, "commit": commits[label], "round": round_,
                             "learners": count, "steps": steps, **measured})
                print(f"round {round_ + 1}/{rounds}: {label} ({commits[label]}), {count:,} "
                      f"learner{'s' * (count > 1)}: {measured['seconds']:.1f} s", file=sys.stderr,
                      flush=True)
    return pd.DataFrame(rows)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(prog="python -m enn_traffic.bench.checkouts",
                                     description=__doc__.split("\n\n")[0])
    parser.add_argument("before", type=Path, help="the checkout before the change")
    parser.add_argument("after", type=Path, help="the checkout after it")
    parser.add_argument("--out", type=Path, required=True, help="the CSV to write")
    parser.add_argument("--learners", type=int, default=3000)
    parser.add_argument("--steps", type=int, default=300)
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--city", type=int, default=1500,
                        help="junctions of the random city (bench crowd_marginal's: 1500)")
    parser.add_argument("--caches", type=Path,
                        default=Path(tempfile.gettempdir()) / "enn-bench-checkouts",
                        help="where each checkout's cache folder is kept")
    args = parser.parse_args(argv)
    table = compare({"before": args.before.resolve(), "after": args.after.resolve()},
                    args.learners, args.steps, args.rounds, args.caches, args.city)
    table.to_csv(args.out, index=False)


if __name__ == "__main__":
    main()
