"""Measure what a change bought: bench crowd_marginal's measurement (learners in one
warmed-up SUMO of the random city, a step's time by part) in two git work trees of the project
(make one with `git worktree add FOLDER COMMIT`), each run in a fresh interpreter with its own
cache folder, the two interleaved over the rounds. Each round runs both with the learners and
with one learner; a round of 3,000 learners and 300 steps took about 3 minutes on 2 cores.

One row per run: the checkout's label and commit, the round, the learners, and what
bench.marginal.marginal_seconds returns; docs/bench.md turns the rows into the cost per
learner and step (the run of one learner taken off), by part."""

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
    """The checkout's commit (12 hex digits) and whether its tree holds changes; "unknown"
    outside git."""
    run = subprocess.run(["git", "-C", str(checkout), "rev-parse", "--short=12", "HEAD"],
                         capture_output=True, text=True)
    dirty = subprocess.run(["git", "-C", str(checkout), "status", "--porcelain",
                            "--untracked-files=no"], capture_output=True, text=True)
    if run.returncode or dirty.returncode:
        return "unknown"
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


def _positive(text: str) -> int:
    value = int(text)
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be at least 1, not {value}")
    return value


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m enn_traffic.bench.checkouts", description=__doc__.split("\n\n")[0],
        formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    parser.add_argument("before", type=Path, help="work tree of the code before the change")
    parser.add_argument("after", type=Path, help="work tree of the code after it")
    parser.add_argument("--out", type=Path, required=True, help="the CSV to write")
    parser.add_argument("--learners", type=_positive, default=3000,
                        help="learners in the larger run")
    parser.add_argument("--steps", type=_positive, default=300, help="0.1 s steps timed")
    parser.add_argument("--rounds", type=_positive, default=3, help="rounds of both")
    parser.add_argument("--city", type=_positive, default=1500,
                        help="junctions of the random city (bench crowd_marginal's)")
    parser.add_argument("--caches", type=Path,
                        default=Path(tempfile.gettempdir()) / "enn-bench-checkouts",
                        help="where each checkout's cache folder is kept")
    args = parser.parse_args(argv)
    checkouts = {"before": args.before.resolve(), "after": args.after.resolve()}
    for label, path in checkouts.items():
        if not (path / "enn_traffic" / "bench" / "marginal.py").is_file():
            parser.error(f"{label}: {path} is not a work tree of the project with bench "
                         "crowd_marginal (make one with `git worktree add FOLDER COMMIT`)")
    table = compare(checkouts, args.learners, args.steps, args.rounds, args.caches,
                    args.city)
    table.to_csv(args.out, index=False)
    return 0


if __name__ == "__main__":
    sys.exit(main())
