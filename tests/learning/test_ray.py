"""The Ray executor with a real local Ray: the same results as the local evaluator."""

import numpy as np
import pandas as pd
import pytest
import ray  # the development install carries Ray: a missing Ray fails, never skips
from conftest import FIG7_RUNS, assert_same_run, local_and_spread

from enn_traffic.config import load_scenario
from enn_traffic.learning.evaluators import RayEvaluator
from enn_traffic.runs.run import evolve


@pytest.fixture(scope="module")
def local_ray():
    ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False,
             configure_logging=False)
    yield
    ray.shutdown()


@pytest.mark.parametrize("workers", [1, 2])
def test_ray_workers_give_the_local_results(local_ray, root, workers):
    scenario = load_scenario(root / "scenarios" / "arena_strategy2.toml")
    population = np.random.default_rng(3).uniform(-1, 1, (11, 68))
    local, spread = local_and_spread(scenario, population, 5,
                                     RayEvaluator(scenario, workers=workers))
    np.testing.assert_array_equal(local.steps, spread.steps)
    np.testing.assert_array_equal(local.suffered, spread.suffered)
    np.testing.assert_array_equal(local.fitness, spread.fitness)


def test_a_run_on_ray_is_the_local_run(local_ray, root, tmp_path):
    scenario = load_scenario(root / "scenarios" / "navigation_narrow.toml").with_overrides(
        ga={"population_size": 30, "generations": 3})
    on_local = evolve(scenario, tmp_path / "local", progress=False)
    evaluator = RayEvaluator(scenario, workers=2)
    try:
        on_ray = evolve(scenario, tmp_path / "ray", evaluator=evaluator, progress=False)
    finally:
        evaluator.close()
    columns = ["best_fitness", "mean_fitness", "min_fitness", "vehicle_steps"]
    assert on_local[columns].equals(on_ray[columns])


def test_reproduce_with_whole_runs_on_ray_gives_the_local_runs(local_ray, quick_fig7, tmp_path):
    """``reproduce --executor ray``: each seed's run is a Ray task; the runs and the table are
    those of the local, one-after-another call."""
    from enn_traffic.experiments.reproduce import reproduce

    out = tmp_path / "ray"
    reproduce(out, quick=True, only=["fig7"], progress=False, executor="ray")
    for run in FIG7_RUNS:
        assert_same_run(quick_fig7 / run, out / run)
    pd.testing.assert_frame_equal(pd.read_csv(quick_fig7 / "fig7.csv"),
                                  pd.read_csv(out / "fig7.csv"))


def test_batch_evaluation_on_ray_gives_the_local_table(local_ray, root, tmp_path):
    """``evaluate --executor ray``: every (controller, scenario) pair a Ray task."""
    from enn_traffic.runs.controller import Controller
    from enn_traffic.runs.evaluate import evaluate_batch

    scenario = load_scenario(root / "scenarios" / "arena_strategy3.toml")
    genes = np.random.default_rng(4).uniform(-1, 1, (2, 68))
    controllers = {f"c{i}": Controller.from_scenario(scenario, g, 0.0, 0)
                   for i, g in enumerate(genes)}
    scenarios = [scenario, load_scenario(root / "scenarios" / "unseen_loop.toml")]
    local = evaluate_batch(controllers, scenarios, episodes=2, progress=False)
    on_ray = evaluate_batch(controllers, scenarios, episodes=2, executor="ray", progress=False)
    pd.testing.assert_frame_equal(local, on_ray)


def test_ray_starts_under_a_temporary_folder_too_long_for_its_sockets(tmp_path, root):
    """With TMPDIR 170 characters deep, a local Ray died in a traceback (its sockets' paths
    past a Unix socket's 107 bytes); now it starts in /tmp/ray-UID and evaluate runs."""
    import os
    import subprocess
    import sys

    long = tmp_path / ("l" * 60) / ("m" * 60) / ("n" * 40)
    long.mkdir(parents=True)
    controller = root / "results" / "paper" / "controllers" / "table1"
    done = subprocess.run(
        [sys.executable, "-m", "enn_traffic", "evaluate", str(next(controller.glob("*.npz"))),
         "navigation_narrow", "--executor", "ray", "--episodes", "2", "--quiet"],
        env={**os.environ, "TMPDIR": str(long)}, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr[-2000:]
    assert "collision" in done.stdout or "capped" in done.stdout
