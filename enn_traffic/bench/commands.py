"""Whole commands as a user meets them, each timed from its start: the README's main job
with an empty cache, ``reproduce --quick``, ``bench --quick``, and the README's test command in
a clone of the checkout."""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numba
import numpy as np
import pandas as pd


def first_run(quick: bool = False) -> pd.DataFrame:
    """The README's main command as a new user runs it: ``enn-traffic run navigation_narrow``
    with an empty cache folder (numba compiles the kernels), then once more with the kernels
    it cached; each timed as a whole command (the same with ``quick``)."""
    rows = []
    runs = 2
    with tempfile.TemporaryDirectory(prefix="enn-bench-first-") as folder:
        env = {**os.environ, "ENN_TRAFFIC_CACHE": str(Path(folder) / "cache")}
        env.pop("NUMBA_CACHE_DIR", None)  # derived from the empty cache folder
        for run in range(runs):
            started = time.perf_counter()
            subprocess.run([sys.executable, "-m", "enn_traffic", "run", "navigation_narrow",
                            "--out", str(Path(folder) / f"run{run}"), "--quiet"],
                           env=env, check=True, capture_output=True)
            rows.append({"workload": "first contact: enn-traffic run navigation_narrow "
                         "(P=200, 50 generations)",
                         "implementation": "empty cache: numba compiles" if run == 0
                         else "kernels from the cache", "threads": numba.get_num_threads(),
                         "seconds": time.perf_counter() - started})
    table = pd.DataFrame(rows)
    table["speedup_vs_reference"] = np.nan
    return table


def reproduce_quick(quick: bool = False) -> pd.DataFrame:
    """``enn-traffic reproduce --quick`` (whether or not the bench is ``quick``) into an empty
    folder with an empty cache folder (SUMO's warm-ups simulated again) and the kernels numba
    compiled before (once per install), timed as a whole command; and each experiment's wall time
    from its ``summary.json``."""
    with tempfile.TemporaryDirectory(prefix="enn-bench-reproduce-") as folder:
        env = {**os.environ, "ENN_TRAFFIC_CACHE": str(Path(folder) / "cache"),
               "NUMBA_CACHE_DIR": os.environ["NUMBA_CACHE_DIR"]}
        out = Path(folder) / "out"
        started = time.perf_counter()
        subprocess.run([sys.executable, "-m", "enn_traffic", "reproduce", "--quick", "--out",
                        str(out)], env=env, check=True, capture_output=True)
        total = time.perf_counter() - started
        records = json.loads((out / "summary.json").read_text(encoding="utf-8"))
    rows = [{"workload": "reproduce --quick", "implementation": name,
             "threads": numba.get_num_threads(), "seconds": record["seconds"]}
            for name, record in records.items()]
    rows.append({"workload": "reproduce --quick", "implementation": "the whole command",
                 "threads": numba.get_num_threads(), "seconds": total})
    table = pd.DataFrame(rows)
    table["speedup_vs_reference"] = np.nan
    return table


def bench_quick(quick: bool = False) -> pd.DataFrame:
    """``enn-traffic bench --quick`` timed as a whole command, as a user's second call meets it
    (whether or not the bench is ``quick``): a first call, untimed, leaves the kernels compiled and
    the networks the bench generates in the cache folder. One row: the second call's seconds and how
    many rows its table has."""
    with tempfile.TemporaryDirectory(prefix="enn-bench-quick-") as folder:
        table = Path(folder) / "quick.csv"
        subprocess.run([sys.executable, "-m", "enn_traffic", "bench", "--quick", "--out",
                        str(table)], check=True, capture_output=True)  # networks, kernels
        started = time.perf_counter()
        subprocess.run([sys.executable, "-m", "enn_traffic", "bench", "--quick", "--out",
                        str(table)], check=True, capture_output=True)
        total = time.perf_counter() - started
        rows = len(pd.read_csv(table))
    return pd.DataFrame([{"workload": "bench --quick", "implementation": "the whole command",
                          "threads": numba.get_num_threads(), "rows": rows, "seconds": total,
                          "speedup_vs_reference": np.nan}])


def test_suite(quick: bool = False) -> pd.DataFrame:
    """The README's test command (``pytest``, its install not timed) in a fresh clone of the
    project's git checkout, as a contributor meets it (whether or not the bench is ``quick``):
    first with empty caches
    (numba compiles every kernel, SUMO's warm-ups are simulated, pytest's cache is new), then
    again in the same clone (warm). The clone's package is the one imported, by the tests and
    by the commands they start. Needs the source checkout (an installed wheel has no tests)."""
    from enn_traffic.core.errors import InputError

    root = Path(__file__).resolve().parents[2]
    if not (root / ".git").exists() or not (root / "tests").is_dir():
        raise InputError("times the README's test command in a clone of the project's git "
                         f"checkout; {root} is not one (an installed package has no tests)",
                         key="test_suite")
    rows = []
    with tempfile.TemporaryDirectory(prefix="enn-bench-tests-") as folder:
        clone = Path(folder) / "clone"
        subprocess.run(["git", "clone", "--quiet", str(root), str(clone)], check=True)
        env = {**os.environ, "ENN_TRAFFIC_CACHE": str(Path(folder) / "cache"),
               "PYTHONPATH": str(clone)}
        env.pop("NUMBA_CACHE_DIR", None)  # derived from the empty cache folder
        for cache in ("empty caches: numba compiles, SUMO warms up", "warm: the same clone again"):
            started = time.perf_counter()
            done = subprocess.run([sys.executable, "-m", "pytest", "-rf"], cwd=clone, env=env,
                                  capture_output=True, text=True)
            seconds = time.perf_counter() - started
            lines = done.stdout.strip().splitlines() or [""]
            last = lines[-1]
            if done.returncode != 0:
                failed = "\n".join(line for line in lines if line.startswith("FAILED"))
                raise RuntimeError(f"pytest failed in the clone ({last}):\n{failed}")
            passed = re.search(r"(\d+) passed", last)
            rows.append({"workload": "the README's test command: pytest (2 workers)",
                         "implementation": cache, "threads": numba.get_num_threads(),
                         "rows": int(passed.group(1)) if passed else np.nan,
                         "seconds": seconds})
    table = pd.DataFrame(rows)
    table["speedup_vs_reference"] = np.nan
    return table
