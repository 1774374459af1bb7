"""The GA-against-PPO comparison: the GA's curve, its budget and its test scores; PPO's
adapter when Stable-Baselines3 is installed (the optional ``rl`` extra)."""

import numpy as np
import pytest

from enn_traffic import baseline
from enn_traffic.cli import main
from enn_traffic.shipped import shipped_scenario


def test_the_ga_curve_spends_its_budget_and_improves_on_the_test_track(tmp_path):
    scenario = shipped_scenario("navigation_narrow").with_overrides(
        ga={"population_size": 30})
    curve = baseline.ga_curve(scenario, 60_000, seed=1)
    assert curve["learner_steps"].is_monotonic_increasing
    assert curve["learner_steps"].iloc[-1] >= 60_000
    assert curve["learner_steps"].iloc[-2] < 60_000  # it stops once the budget is spent
    assert curve["test_fitness"].iloc[-1] > 5 * curve["test_fitness"].iloc[0]


def test_a_bad_method_is_refused_with_status_2(capsys):
    assert main(["baseline", "navigation_narrow", "--methods", "GA,DQN"]) == 2
    assert "--methods" in capsys.readouterr().err


def test_ppo_learns_through_the_compiled_vector_env():
    pytest.importorskip("stable_baselines3")
    curve = baseline.ppo_curve(shipped_scenario("navigation_narrow"), 40_000, seed=1,
                               checkpoints=2)
    assert len(curve) >= 1
    assert np.isfinite(curve["test_fitness"]).all()
