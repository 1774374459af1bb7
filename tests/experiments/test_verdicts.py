"""The verdict rule and the intervals of the verdict table (issue 80)."""

import numpy as np
import pandas as pd
import pytest

from enn_traffic.experiments.verdicts import (
    paper_table1_ratio,
    share_of_seeds,
    table1_ratio,
    verdict,
)


@pytest.mark.parametrize(("low", "high", "null", "side", "figure", "word"), [
    (0.2, 0.4, 0.0, "above", None, "reproduced"),  # a direction claim, met
    (0.2, 0.4, 0.0, "above", 0.3, "reproduced"),  # the paper's figure inside
    (0.2, 0.4, 0.0, "above", 0.9, "in direction only"),  # ... outside
    (0.0, 0.4, 0.0, "above", 0.3, "not reproduced"),  # reaches the null
    (-0.4, -0.2, 0.0, "above", None, "not reproduced"),  # beyond it
    (-0.4, -0.2, 0.0, "below", -0.3, "reproduced"),
    (-3.0, 5.0, None, None, None, "beyond the paper"),
])
def test_the_word_follows_from_the_interval(low, high, null, side, figure, word):
    assert verdict(low, high, null, side, figure) == word


def test_a_share_of_seeds_has_its_clopper_pearson_interval():
    """5 of 5: the exact 90% interval's lower end solves p⁵ = 0.05; 4 of 5 stops short of 1,
    so the paper's figure (every run) lies outside it; 0 of 5 reaches the null."""
    every = share_of_seeds("x", pd.Series([True] * 5))
    assert every["low"] == pytest.approx(0.05 ** (1 / 5)) and every["high"] == 1.0
    assert every["verdict"] == "reproduced"
    assert share_of_seeds("x", pd.Series([True] * 4 + [False]))["verdict"] == "in direction only"
    assert share_of_seeds("x", pd.Series([False] * 5))["verdict"] == "not reproduced"


def test_table1s_ratio_is_the_diagonal_over_the_rest():
    """Two strategies, three situations each; the specialists live 300 steps among their own
    traffic and 100 among the other's in every situation: 3× with an interval of width 0,
    each on top of its row. The paper's matrix gives its 4.9."""
    episodes = pd.DataFrame([
        {"controller": f"strategy{c}", "scenario": f"arena_strategy{s}", "situation": k,
         "fitness": 300.0 if c == s else 100.0}
        for c in (1, 2) for s in (1, 2) for k in range(3)])
    assert table1_ratio(episodes, np.random.default_rng(0), draws=50) == (3.0, 3.0, 3.0, 2)
    assert paper_table1_ratio() == pytest.approx(4.9, abs=0.01)
