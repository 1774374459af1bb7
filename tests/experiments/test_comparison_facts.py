"""The comparison's facts (enn_traffic.experiments.gradient_rl.facts) are computed from its
folder's tables: a changed table changes them."""

import shutil

import pandas as pd
import pytest

from enn_traffic.experiments import facts


@pytest.fixture
def folder(root, tmp_path):
    copy = tmp_path / "baseline"
    shutil.copytree(root / "results" / "baseline", copy,
                    ignore=shutil.ignore_patterns("controllers", "*.png"))
    return copy


def test_a_spin_under_the_chosen_rule_moves_the_choice_down(folder):
    """A centre-keeping life ruled a spin under 40 m²: the second rule becomes 32 m²."""
    assert facts.computed(folder, "baseline/spin_rule") == {"chosen_variance": 40.0}
    table = pd.read_csv(folder / "spin_rule.csv")
    table.loc[(table["spin_variance"] == 40.0) & (table["gain"] == 4.0), "spins"] = 1
    table.to_csv(folder / "spin_rule.csv", index=False)
    assert facts.computed(folder, "baseline/spin_rule") == {"chosen_variance": 32.0}


def test_a_changed_run_moves_its_groups_fitness_and_nothing_else(folder):
    """One PPO seed on the narrow track scoring 200 more: its group's mean rises by 200 / 10
    and its greatest is that seed's; every other group's row stays."""
    before = facts.computed(folder, "baseline/fitness")["rows"]
    runs = pd.read_csv(folder / "comparison.csv")
    seed = ((runs["scenario"] == "navigation_narrow") & (runs["method"] == "PPO")
            & (runs["budget_steps"] == 1_000_000) & (runs["seed"] == 1))
    runs.loc[seed, "test_fitness"] += 200
    runs.to_csv(folder / "comparison.csv", index=False)
    after = facts.computed(folder, "baseline/fitness")["rows"]
    changed = [(old, new) for old, new in zip(before, after, strict=True) if old != new]
    assert len(changed) == 1
    old, new = changed[0]
    assert (new["scenario"], new["method"], new["budget_steps"]) == (
        "navigation_narrow", "PPO", 1_000_000)
    assert new["test_fitness"] == pytest.approx(old["test_fitness"] + 20)
    assert new["greatest"] == pytest.approx(max(old["greatest"],
                                                runs.loc[seed, "test_fitness"].item()))
