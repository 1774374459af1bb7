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
