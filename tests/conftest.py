from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture
def root() -> Path:
    return ROOT


def local_and_spread(scenario, population, generation, evaluator):
    """The results of the local evaluator and of ``evaluator`` (closed afterwards) on the
    same population and generation."""
    from enn_traffic.evolution.evaluate import LocalEvaluator

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
