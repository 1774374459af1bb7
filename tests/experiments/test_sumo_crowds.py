"""The SUMO Tables 3–4 builder: means and bootstrap intervals over situations."""

import numpy as np
import pandas as pd
import pytest

from enn_traffic.experiments.crowds.sumo import table
from enn_traffic.report.stats import bootstrap_interval as interval


def test_interval_of_equal_values_is_that_value_and_brackets_the_mean_otherwise():
    rng = np.random.default_rng(0)
    assert interval(np.full(5, 0.2), rng) == pytest.approx((0.2, 0.2))
    values = np.array([0.0, 0.1, 0.2, 0.3, 1.0])
    low, high = interval(values, rng)
    assert 0.0 <= low < values.mean() < high <= 1.0


def test_table_gives_each_strategys_means_over_its_situations():
    """Strategy 1: collision rates 0.1 and 0.3 (mean 0.2), SSM conflicts 10 and 20 per hour,
    2-D conflicts 40 and 60; strategy 2: a single situation."""
    situations = pd.DataFrame({
        "strategy": [1, 1, 2], "situation": [0, 1, 0],
        "initial": [0.1, 0.3, 0.5], "initial_conflicts": [10.0, 20.0, 30.0],
        "initial_conflicts_2d": [40.0, 60.0, 0.0],
        "winner": [0.0, 0.1, 0.2], "winner_conflicts": [0.0, 4.0, 2.0],
        "winner_conflicts_2d": [1.0, 2.0, 3.0]})
    result = table(situations, ["initial", "winner"]).set_index("strategy")
    assert result.loc[1, "initial_collisions_per_s"] == pytest.approx(0.2)
    assert result.loc[1, "initial_conflicts_per_h"] == pytest.approx(15.0)
    assert result.loc[1, "initial_conflicts_2d_per_h"] == pytest.approx(50.0)
    assert result.loc[1, "winner_collisions_per_s"] == pytest.approx(0.05)
    assert result.loc[2, "initial_low"] == result.loc[2, "initial_high"] == pytest.approx(0.5)
    assert result.loc[1, "initial_low"] <= 0.2 <= result.loc[1, "initial_high"]


def test_the_crowd_settings_are_the_crowd_keys():
    """One record of how crowds learn, named as ``[crowd]`` names it: every key of the
    section is a setting of the same name and default, and a scenario's keys become the
    settings unchanged."""
    from dataclasses import fields

    from enn_traffic.config import CrowdConfig
    from enn_traffic.experiments.crowds.settings import CrowdSettings

    keys = set(CrowdConfig.model_fields) - {"counting"}
    assert keys <= {f.name for f in fields(CrowdSettings)}
    assert all(getattr(CrowdSettings(), key) == getattr(CrowdConfig(), key) for key in keys)
    chosen = CrowdConfig(learning_s=300.0, window_s=50.0, situations=3)
    settings = CrowdSettings.of(chosen)
    assert (settings.learning_s, settings.window_s, settings.situations, settings.windows) == (
        300.0, 50.0, 3, 6)
