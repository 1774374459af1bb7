"""The generalisation matrix from generalization.csv's rows (issue 25)."""

import math

import pandas as pd

from enn_traffic.experiments.navigation import unseen_matrix


def test_the_matrix_counts_unseen_tracks_only():
    rows = [  # trained_on, seed, track, seen, capped
        ("narrow", 1, "a", True, True), ("narrow", 2, "a", True, False),
        ("narrow", 1, "b", False, True), ("narrow", 2, "b", False, False),
        ("mixed", 1, "a", False, True), ("mixed", 2, "a", False, True),
        ("mixed", 1, "b", False, False), ("mixed", 2, "b", False, False),
        ("mixed", 1, "train_x", True, True),
    ]
    table = pd.DataFrame(rows, columns=["trained_on", "seed", "track", "seen", "capped"])
    matrix = unseen_matrix(table, ["narrow", "mixed"], ["a", "b", "c"])
    assert list(matrix.index) == ["narrow", "mixed"] and list(matrix.columns) == ["a", "b", "c"]
    assert math.isnan(matrix.loc["narrow", "a"])  # its training track: not counted
    assert matrix.loc["narrow", "b"] == 0.5 and matrix.loc["mixed", "a"] == 1.0
    assert matrix.loc["mixed", "b"] == 0.0
    assert matrix["c"].isna().all()  # a track no one drove is blank, not an error
