import os

# Under `pytest -n N` each worker's compiled kernels, and the commands it starts, run cores ÷ N
# threads: N workers of a thread per core each would put N threads on every core (docs/bench.md,
# "Sharing the cores"). Set before anything imports numba, which reads it once.
if int(os.environ.get("PYTEST_XDIST_WORKER_COUNT", "1")) > 1:
    os.environ.setdefault("NUMBA_NUM_THREADS", str(max(
        1, (os.cpu_count() or 1) // int(os.environ["PYTEST_XDIST_WORKER_COUNT"]))))

from pathlib import Path

import pytest

from enn_traffic.config import load_scenario
from enn_traffic.sim.arena import ArenaWorld

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="session", autouse=True)
def network_cache(request, tmp_path_factory) -> Path:
    """A cache folder of the tests' own, in pytest's cache folder (subprocesses inherit it), so
    that the tests neither read nor fill the user's cache. It lasts from one test session to
    the next and is shared by the ``-n`` workers, as the user's does: entries are keyed by what
    they were built from and written whole, so none is ever stale or half-read. Tests of the
    cache itself give their own folder. (Without pytest's cache, ``-p no:cacheprovider``: a
    folder of the session's own.)"""
    cache = getattr(request.config, "cache", None)
    folder = (cache.mkdir("enn-traffic-cache") if cache is not None
              else tmp_path_factory.mktemp("cache"))
    os.environ["ENN_TRAFFIC_CACHE"] = str(folder)
    return folder


@pytest.fixture
def root() -> Path:
    return ROOT


@pytest.fixture(scope="module")
def render():
    """docs/_generate/render.py, the documents' renderer (a folder of scripts, not a package),
    as a module, its contexts importable while the test runs."""
    import importlib
    import sys

    generate = str(ROOT / "docs" / "_generate")
    sys.path.insert(0, generate)
    try:
        yield importlib.import_module("render")
    finally:
        sys.path.remove(generate)


@pytest.fixture(scope="module")
def road_net(tmp_path_factory):
    """The straight two-way road of :mod:`sumo_road`, built once per test module."""
    from sumo_road import build_road_net

    return build_road_net(tmp_path_factory.mktemp("road"))


@pytest.fixture
def small(root):
    """The narrow track with a small, quick GA."""
    return load_scenario(root / "scenarios" / "navigation_narrow.toml").with_overrides(
        ga={"population_size": 30, "generations": 40})


@pytest.fixture(scope="session")
def quick_fig7(tmp_path_factory) -> Path:
    """``reproduce --quick --only fig7`` run once, uninterrupted, through the command line."""
    import subprocess
    import sys

    out = tmp_path_factory.mktemp("reproduce") / "fig7"
    result = subprocess.run([sys.executable, "-m", "enn_traffic", "reproduce", "--quick",
                             "--only", "fig7", "--out", str(out), "--quiet"],
                            capture_output=True, text=True)
    assert result.returncode == 0, result.stderr
    return out


FIG7_RUNS = ("runs/navigation_narrow/seed1", "runs/navigation_narrow/seed2")


def local_and_spread(scenario, population, generation, evaluator):
    """The results of the local evaluator and of ``evaluator`` (closed afterwards) on the
    same population and generation."""
    from enn_traffic.learning.evaluators import LocalEvaluator

    local = LocalEvaluator(scenario).evaluate(population, generation)
    try:
        spread = evaluator.evaluate(population, generation)
    finally:
        evaluator.close()
    return local, spread


def assert_same_run(expected, got) -> None:
    """Two run folders hold the same generations.csv (but elapsed time) and final population."""
    import numpy as np
    import pandas as pd

    pd.testing.assert_frame_equal(
        pd.read_csv(expected / "generations.csv").drop(columns="elapsed_s"),
        pd.read_csv(got / "generations.csv").drop(columns="elapsed_s"))
    with np.load(expected / "checkpoint.npz") as a, np.load(got / "checkpoint.npz") as b:
        np.testing.assert_array_equal(a["population"], b["population"])


TWO_CARS = """
name = "two_cars"
[track]
net = "{net}"
start_xy = [{lx}, {ly}]
start_heading_deg = 0.0
[vehicle]
width = 2.5
[sensor]
beams = 3
[traffic]
strategy = "straight"
turn_distance = 0.0
starts_xy = [[{tx}, {ty}]]
start_heading_deg = [{th}, {th}]
"""


def two_cars(tmp_path, root, learner, other, heading):
    """The arena with the learner and one straight driver (no wall turns), width 2.5 m."""
    path = tmp_path / "two.toml"
    path.write_text(TWO_CARS.format(net=root / "sumo_nets" / "arena.net.xml", lx=learner[0],
                                    ly=learner[1], tx=other[0], ty=other[1], th=heading))
    return ArenaWorld(load_scenario(path))
