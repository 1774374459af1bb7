"""The table builders on hand-made inputs: Table 1's pattern line, Fig. 11's rises and the
paper-beside-ours tables of summary.md (issue 26)."""

import numpy as np
import pandas as pd
import pytest

from enn_traffic.experiments import fig11, table1
from enn_traffic.report.paper_tables import paper_tables


def test_table1_line_counts_the_rows_whose_diagonal_is_highest():
    matrix = np.array([[900.0, 100, 100, 100],
                       [200, 800, 900, 100],  # row 2: strategy 3 beats its own diagonal
                       [100, 100, 700, 100],
                       [100, 100, 100, 600]])
    line = table1.summary_line(matrix, "table1")
    # diagonal 750 on average; off-diagonal (300 + 1200 + 300 + 300) / 12 = 175
    assert "mean diagonal 750, mean off-diagonal 175 (ratio 4.29" in line
    assert "in 3 of 4 rows" in line


def test_fig11_rise_is_the_last_five_over_the_first_generation():
    generations = pd.DataFrame({"best_fitness": [100.0, 200, 300, 400, 500, 600, 700],
                                "mean_fitness": [10.0, 10, 20, 20, 20, 20, 20]})
    on_test = np.array([50.0, 60, 70, 80, 90, 100, 110])
    row = fig11.run_row(2, 1, generations, on_test)
    assert row["rise"] == pytest.approx(500 / 100)  # mean of 300..700
    assert row["mean_rise"] == pytest.approx(2.0)
    assert row["held_out_rise"] == pytest.approx(90 / 50)
    assert np.isnan(fig11.run_row(2, 1, generations, None)["held_out_rise"])
    rows = pd.DataFrame([row, {**row, "seed": 2, "rise": 1.0}, {**row, "seed": 3, "rise": 9.0}])
    assert "strategy 2: 5.0x" in fig11.summary_line(rows, "fig11")  # the median run


def test_paper_tables_set_ours_beside_the_papers(tmp_path):
    pd.DataFrame({"training_strategy": [1, 2, 3, 4],
                  **{f"deploy_{j}": [float(10 * i + j) for i in range(1, 5)]
                     for j in range(1, 5)}}).to_csv(tmp_path / "table1.csv", index=False)
    pd.DataFrame({"strategy": [1, 2, 3, 4], "initial_collisions_per_s": [0.1, 0.2, 0.3, 0.4],
                  "after_collisions_per_s": [0.02, 0.03, 0.04, 0.05]}).to_csv(
        tmp_path / "table3.csv", index=False)
    pd.DataFrame({"strategy": [1, 2, 3, 4],
                  "initial_after_collisions_per_s": [0.09, 0.19, 0.29, 0.39],
                  "population_collisions_per_s": [0.01, 0.02, 0.03, 0.04]}).to_csv(
        tmp_path / "table4.csv", index=False)
    lines = paper_tables(tmp_path)
    table1 = lines[lines.index("| trained \\ deployed | 1 | 2 | 3 | 4 |") + 2:][:4]
    # the paper's Table 1 (its text, row by row) beside ours: entry (i, j) = 10 i + j
    assert table1 == ["| 1 | 2115 / 11 | 544 / 12 | 558 / 13 | 432 / 14 |",
                      "| 2 | 595 / 21 | 2305 / 22 | 136 / 23 | 931 / 24 |",
                      "| 3 | 159 / 31 | 351 / 32 | 3050 / 33 | 460 / 34 |",
                      "| 4 | 559 / 41 | 334 / 42 | 1080 / 43 | 2560 / 44 |"]
    # Table 4's initial column is the paper's baseline, the first span Table 3 has too; the
    # initial drivers over the later span stand beside it, not in its place
    header = "| strategy | initial | after | here: the initial drivers driving on |"
    table4 = lines[lines.index(header) + 2:][:4]
    assert table4 == ["| 1 | 16.33 / 0.1 | 2.11 / 0.01 | 0.09 |",
                      "| 2 | 20.05 / 0.2 | 1.58 / 0.02 | 0.19 |",
                      "| 3 | 16.82 / 0.3 | 1.76 / 0.03 | 0.29 |",
                      "| 4 | 13.49 / 0.4 | 1.9 / 0.04 | 0.39 |"]


def test_sumo_tables_carry_paired_intervals_into_the_summary(tmp_path):
    """Two situations per strategy: Table 4's difference is the mean of the paired
    differences (strategy 1: -0.2 and -0.3, so -0.25 with an interval inside [-0.3, -0.2]),
    Table 3 the same for the winner, and summary.md's SUMO Table 4 sets the paper's rates
    beside these."""
    from enn_traffic.experiments.crowds.sumo import CONFLICTS, write_tables

    arms = {"initial": [0.5, 0.7, 0.6, 0.6], "winner": [0.1, 0.2, 0.0, 0.0],
            "initial_after": [0.2, 0.4, 0.6, 0.6], "winner_after": [0.0, 0.0, 0.1, 0.1],
            "population": [0.0, 0.1, 0.2, 0.2], "learning": [0.1, 0.1, 0.1, 0.1]}
    situations = pd.DataFrame({"strategy": [1, 1, 2, 2], "situation": [0, 1, 0, 1], **arms,
                               **{f"{arm}_conflicts": [3.0, 5.0, 0.0, 0.0]
                                  for arm in CONFLICTS},
                               **{f"{arm}_conflicts_2d": [6.0, 8.0, 1.0, 1.0]
                                  for arm in CONFLICTS}})
    learners = pd.DataFrame({"strategy": [1, 2], "situation": [0, 0], "learner": [0, 0],
                             "generations_bred": [3, 4]})
    lines = write_tables(tmp_path / "sumo", situations, learners)
    table3 = pd.read_csv(tmp_path / "sumo" / "table3.csv").set_index("strategy")
    table4 = pd.read_csv(tmp_path / "sumo" / "table4.csv").set_index("strategy")
    assert table3.loc[1, "winner_minus_initial"] == pytest.approx(-0.45)
    assert table4.loc[1, "population_minus_initial_after"] == pytest.approx(-0.25)
    assert -0.3 <= table4.loc[1, "population_minus_initial_after_low"] <= -0.25
    assert -0.25 <= table4.loc[1, "population_minus_initial_after_high"] <= -0.2
    assert table4.loc[2, "population_minus_winner_after"] == pytest.approx(0.1)
    assert table4.loc[1, "population_conflicts_per_h"] == pytest.approx(4.0)
    assert table4.loc[1, "population_conflicts_2d_per_h"] == pytest.approx(7.0)
    assert "median generations bred per learner 3, 4" in lines[1]
    text = "\n".join(paper_tables(tmp_path))
    assert "| 1 | 16.33 / 0.6 | 2.11 / 0.05 | -0.25 (" in text  # initial: the first window


def test_regime_time_bases():
    """1.575 lives lost per second at steps of 0.1 s are 0.1575 per step and 15.75 per 100
    steps (docs/results.md says which lies in the paper's range)."""
    from enn_traffic.experiments.regime import time_bases

    bases = time_bases(np.array([1.575, 0.1575]), 0.1)
    np.testing.assert_allclose(bases["lives_lost_per_step"], [0.1575, 0.0158])
    np.testing.assert_allclose(bases["lives_lost_per_100_steps"], [15.75, 1.575])


def test_the_learning_curves_verb_follows_its_paired_interval():
    """Each situation's first and last tenth of the learning: a curve that climbs in every
    situation "rises", one that falls in every situation "falls", and one that goes up in
    half and down in the other half moves neither way (its interval spans 0; docs/results.md
    chooses its verb from the interval's sign)."""
    from enn_traffic.experiments.crowds.stats import learning_ends, trend

    def windows(slopes):
        rows = []
        for situation, slope in enumerate(slopes):
            for span in range(20):  # first and last tenth: 2 spans each
                rate = 0.05 + slope * span
                rows.append({"strategy": 1, "situation": situation,
                             "window_start_s": 100.0 * span, "learning": rate,
                             "initial_drivers": 0.1, "winner_driving_on": 0.01})
        return pd.DataFrame(rows)

    ends = learning_ends(windows([0.001] * 6))
    assert ends["learning_first"].iloc[0] == pytest.approx(0.0505)  # spans 0, 1
    assert ends["learning_last"].iloc[0] == pytest.approx(0.0685)  # spans 18, 19
    change, low, high = trend(ends)
    assert change == pytest.approx(0.018) and low > 0
    assert trend(learning_ends(windows([-0.001] * 6)))[2] < 0
    _, low, high = trend(learning_ends(windows([0.001, -0.001] * 3)))
    assert low < 0 < high
