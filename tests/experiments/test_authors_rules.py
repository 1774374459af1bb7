"""The authors' set-up's three rules, each alone and together, against the set-up without
them (issue 80)."""

from dataclasses import fields

import numpy as np
import pandas as pd
import pytest

from enn_traffic.experiments.ablation import AuthorsRules
from enn_traffic.experiments.authors_rules import (
    MEASURES,
    NONE,
    VARIANTS,
    Steps,
    rules_table,
    situation_rows,
)

THREE = ("respawn_at_start", "spin_rule", "until_finished")


def test_each_variant_adds_its_own_rule_to_none_and_all_three_is_the_ablations_arm():
    assert VARIANTS["all three"] == AuthorsRules()  # the ablation's authors' set-up
    none = VARIANTS[NONE]
    assert not any(getattr(none, name) for name in THREE)
    alone = [VARIANTS[name] for name in list(VARIANTS)[1:-1]]
    changed = [{f.name for f in fields(AuthorsRules) if getattr(v, f.name) != getattr(none, f.name)}
               for v in alone]
    assert changed == [{"respawn_at_start"}, {"spin_rule"}, {"until_finished"}]


def test_the_fall_and_the_paired_differences_are_the_hand_computed_ones():
    """``none`` falls from 0.1 to 0.05 in every situation (50%); the spin rule doubles both
    spans (still 50%, first span +0.1 and after +0.05 in every situation: intervals of width
    0); the other variants equal ``none``."""
    rows = []
    for name in VARIANTS:
        scale = 2.0 if name == "their spin rule" else 1.0
        rows += [{"situation": s, "variant": name, "first_span": 0.1 * scale,
                  "after": 0.05 * scale, "after_minus_first_span": -0.05 * scale,
                  "learning_s": 100.0, "finished_share": 0.5} for s in range(5)]
    table = rules_table(pd.DataFrame(rows)).set_index("variant")
    assert table["fall"].tolist() == pytest.approx([0.5] * len(VARIANTS))
    assert table.loc[NONE, [f"{m}_vs_none" for m in MEASURES]].isna().all()
    spin = table.loc["their spin rule"]
    assert spin["first_span_vs_none"] == pytest.approx(0.1)
    assert spin["after_vs_none"] == spin["after_vs_none_low"] == pytest.approx(0.05)
    assert spin["after_minus_first_span_vs_none"] == pytest.approx(-0.05)
    others = table.drop([NONE, "their spin rule"])
    assert (others[[f"{m}_vs_none" for m in MEASURES]] == 0).all().all()


def test_a_situation_learns_table_4s_time_unless_until_every_car_finished():
    """A short situation: the variants without the finishing-until rule learn ``seconds``
    exactly; with it, at most ``authors_seconds`` (it stops early when every car finished).
    Respawning at the car's own start and the spin rule change what the first span reads."""
    rows = situation_rows(0, Steps(situations=1, seconds=200.0, authors_seconds=400.0))
    by = {row["variant"]: row for row in rows}
    assert [by[name]["learning_s"] for name in list(VARIANTS)[:3]] == [200.0] * 3
    assert 100.0 <= by["until every car finished"]["learning_s"] <= 400.0
    assert by["until every car finished"]["first_span"] == by[NONE]["first_span"]
    assert by["their spin rule"]["first_span"] != by[NONE]["first_span"]
    assert np.isfinite([row["after"] for row in rows]).all()
