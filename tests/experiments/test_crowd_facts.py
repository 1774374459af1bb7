"""The crowds' facts (Tables 3–4 in the arena and the SUMO families, Table 4's ablation) are
computed from the reproduce folder's tables: a changed table changes them."""

import shutil

import pandas as pd
import pytest

from enn_traffic.experiments import facts


@pytest.fixture
def folder(root, tmp_path):
    copy = tmp_path / "paper"
    shutil.copytree(root / "results" / "paper", copy, ignore=shutil.ignore_patterns("*.png"))
    return copy


def test_a_learning_curve_that_falls_turns_the_trend_down(folder):
    """Every situation's last tenth of the learning 0.01 below its first: the learners' trend
    is -0.01, its interval below 0, where the committed curve rises."""
    assert facts.computed(folder, "paper/tables34")["trend"]["low"] > 0
    ends = pd.read_csv(folder / "table4_learning_ends.csv")
    ends["learning_last"] = ends["learning_first"] - 0.01
    ends.to_csv(folder / "table4_learning_ends.csv", index=False)
    trend = facts.computed(folder, "paper/tables34")["trend"]
    assert trend["change"] == pytest.approx(-0.01)
    assert trend["high"] < 0


def test_a_winner_no_better_than_the_initial_drivers_cuts_nothing(folder):
    """The winner's first span set to the initial drivers' in every situation and strategy:
    the winner's mean reduction and its interval are 0."""
    situations = pd.read_csv(folder / "simultaneous_situations.csv")
    situations["winner"] = situations["initial"]
    situations.to_csv(folder / "simultaneous_situations.csv", index=False)
    means = pd.read_csv(folder / "simultaneous.csv")
    means["winner"] = means["initial"]
    means.to_csv(folder / "simultaneous.csv", index=False)
    cut = facts.computed(folder, "paper/tables34")["reductions"]["winner_vs_initial"]
    assert cut == pytest.approx({"mean": 0.0, "low": 0.0, "high": 0.0})


def test_an_arm_that_bred_nothing_is_idle(folder):
    """Learners from random populations with the cap set to breed no generation: that arm
    joins the idle ones."""
    idle = {"start_population": "random", "stopping": "cap"}
    assert idle not in facts.computed(folder, "paper/table4_ablation")["idle_arms"]
    table = pd.read_csv(folder / "table4_ablation.csv")
    arm = (table["start_population"] == "random") & (table["stopping"] == "cap")
    table.loc[arm, "generations_bred"] = 0
    table.to_csv(folder / "table4_ablation.csv", index=False)
    assert idle in facts.computed(folder, "paper/table4_ablation")["idle_arms"]


def test_the_city_curve_ends_follow_its_table(folder):
    """The city's learning curve doubled: every strategy's first and last tenth double."""
    before = facts.computed(folder, "paper/city_tables34")["curve"]["strategies"]
    curve = pd.read_csv(folder / "city" / "table4_learning.csv")
    curve["collisions_per_vehicle_s"] *= 2
    curve.to_csv(folder / "city" / "table4_learning.csv", index=False)
    after = facts.computed(folder, "paper/city_tables34")["curve"]["strategies"]
    for old, new in zip(before, after, strict=True):
        for end in ("first", "last"):
            assert new["collisions_per_vehicle_s"][end] == pytest.approx(
                2 * old["collisions_per_vehicle_s"][end])
