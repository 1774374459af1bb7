"""The generalisation matrix from generalization.csv's rows (issue 25)."""

import math

import numpy as np
import pandas as pd

from enn_traffic.config.shipped import shipped_scenario
from enn_traffic.core.neural import NetworkSpec
from enn_traffic.experiments.navigation import (
    TEST_TRACKS,
    TRAINED,
    VALIDATION_TRACKS,
    unseen_matrix,
)
from enn_traffic.runs.controller import Controller


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


def test_training_validation_and_test_tracks_are_apart():
    nets = {name: {t.net.name for t in shipped_scenario(name).tracks}
            for name in TRAINED + VALIDATION_TRACKS + TEST_TRACKS}
    validation = set().union(*(nets[name] for name in VALIDATION_TRACKS))
    test = set().union(*(nets[name] for name in TEST_TRACKS))
    mixed = nets["navigation_mixed"]
    assert len(test) == len(TEST_TRACKS) and not test & validation
    assert not mixed & (validation | test)
    # a track keeps its step cap and takes the spin rule of the controller's training
    mixed = shipped_scenario("navigation_mixed")
    controller = Controller.from_scenario(mixed, np.zeros(NetworkSpec(mixed.layer_sizes)
                                                            .chromosome_length), 0.0, 0)
    measured = controller.fit(shipped_scenario(TEST_TRACKS[0]))
    assert measured.episode.max_steps == 20_000
    assert (measured.episode.spin_window, measured.episode.spin_variance) == (300, 300.0)
