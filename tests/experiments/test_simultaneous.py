"""Tables 3–4's protocol (paper §5.5): ranking candidates, the evolved population, the
reduction's interval."""

import numpy as np
import pytest
from conftest import two_cars


@pytest.fixture
def world(tmp_path, root):
    return two_cars(tmp_path, root, (20.0, 50.0), (40.0, 50.0), 180.0)


def test_evolved_population_puts_the_ranked_candidates_first_without_repeats():
    from enn_traffic.experiments.crowds.arena import _evolved_population

    a, b, c, d = (np.full(3, float(k)) for k in range(4))
    population = _evolved_population(np.stack([a, b]), np.stack([b, c, b, d]), size=3)
    np.testing.assert_array_equal(population, np.stack([a, b, c]))


def test_reduction_interval_follows_the_situations():
    import pandas as pd

    from enn_traffic.experiments.crowds.stats import reduction_interval

    rng = np.random.default_rng(0)
    steady = pd.DataFrame({"strategy": [1, 1, 1, 2, 2], "initial": [1, 1, 1, 2, 2],
                           "population": [0.5, 0.5, 0.5, 0, 0]})
    assert reduction_interval(steady, "population", rng) == pytest.approx((0.75, 0.75))
    varied = pd.DataFrame({"strategy": [1] * 6, "initial": [1.0] * 6,
                           "population": [0.0, 0.0, 0.0, 0.4, 0.4, 0.4]})  # 80% on average
    low, high = reduction_interval(varied, "population", rng)
    assert 0.6 < low < 0.8 < high < 1.0


def test_ranking_puts_the_candidate_losing_fewest_lives_on_validation_first(world):
    """The winner of §5.5.1 is the candidate that lost fewest lives per step on the validation
    situations when it drove every vehicle."""
    from enn_traffic.experiments.crowds import arena as simultaneous

    straight = np.zeros(world.spec.chromosome_length)
    circling = straight.copy()
    circling[-1] = 1.0  # spins out
    candidates = np.stack([circling, straight])
    lost = []
    for genes in world.spec.in_source_layout(candidates):  # the layout the arena drives
        runs = [simultaneous._broadcast(world, genes, s, simultaneous.VALIDATION_KEY)[0]
                for s in range(simultaneous.VALIDATION_SITUATIONS)]
        lost.append(sum(int(r.collisions.sum() + r.spins.sum()) for r in runs))
    assert lost[0] != lost[1]
    ranked = simultaneous._ranked(world, candidates)
    np.testing.assert_array_equal(ranked, candidates[np.argsort(lost, kind="stable")])


def test_table4_pairs_the_arms_by_situation():
    """The paired difference's interval is narrow where every situation moves both arms
    alike, though each arm alone varies widely between situations."""
    import pandas as pd

    from enn_traffic.experiments.crowds.stats import table4_comparisons

    base = np.array([0.01, 0.10, 0.05, 0.20, 0.02, 0.15])
    situations = pd.DataFrame({"strategy": 1, "situation": range(6), "population": base,
                               "initial_after": base + 0.02, "winner_after": base - 0.01,
                               "reranked": base[::-1]})
    row = table4_comparisons(situations).iloc[0]
    assert row["population_minus_initial_after"] == pytest.approx(-0.02)
    assert (row["population_minus_initial_after_low"], row["population_minus_initial_after_high"]
            ) == pytest.approx((-0.02, -0.02))
    assert row["population_minus_winner_after_low"] == pytest.approx(0.01)
    assert row["population_minus_reranked_low"] < -0.03 < 0.03 < row[
        "population_minus_reranked_high"]


def test_learning_curve_averages_each_span_over_the_situations():
    import pandas as pd

    from enn_traffic.experiments.crowds.stats import learning_curve

    windows = pd.DataFrame({"strategy": [1, 1, 1, 1], "situation": [0, 0, 1, 1],
                            "window_start_s": [0.0, 100.0, 0.0, 100.0],
                            "learning": [0.1, 0.3, 0.2, 0.5], "initial_drivers": 0.4,
                            "winner_driving_on": 0.05})
    curve = learning_curve(windows)
    assert curve["collisions_per_vehicle_s"].tolist() == pytest.approx([0.15, 0.4])
    assert curve["window_start_s"].tolist() == [0.0, 100.0]


def test_tables_3_and_4_summary_lines():
    import pandas as pd

    from enn_traffic.experiments.crowds.arena import summary_lines

    situations = pd.DataFrame({  # two strategies, two situations each
        "strategy": [1, 1, 2, 2], "situation": [0, 1, 0, 1],
        "initial": [0.10, 0.10, 0.05, 0.05], "winner": [0.02, 0.02, 0.01, 0.01],
        "initial_after": [0.08, 0.08, 0.04, 0.04], "winner_after": [0.01, 0.03, 0.01, 0.01],
        "population": [0.02, 0.02, 0.02, 0.02], "reranked": [0.03, 0.03, 0.01, 0.03]})
    learners = pd.DataFrame({"strategy": [1, 1, 2, 2], "generations_bred": [3, 5, 4, 4]})
    (line,) = summary_lines(situations, learners, "table3")
    # 1 - 0.02/0.10 = 80%, 1 - 0.01/0.05 = 80%
    assert "strategy 1: 0.100 -> 0.020" in line and "mean reduction 80%" in line
    (line,) = summary_lines(situations, learners, "table4")
    # from the paper's baseline: 1 - 0.02/0.10 = 80%, 1 - 0.02/0.05 = 60% -> 70%; from the
    # initial drivers driving on: 1 - 0.02/0.08 = 75%, 1 - 0.02/0.04 = 50% -> 62%
    assert "strategy 1: 0.080 -> 0.020" in line
    assert "the initial drivers' first span, 70%" in line
    assert "from the initial drivers driving on 62%" in line
    # population - winner_after: 0 (pairs +0.01, -0.01), then +0.01 (both); population -
    # reranked: -0.01 (both), then 0 (pairs +0.01, -0.01)
    assert "below the winner driving on in 0 of 2 strategies (0 with the paired interval " \
           "below 0, 1 above)" in line
    assert ("below the re-ranked controllers in 1 of 2 strategies (1 with the paired "
            "interval below 0, 0 above)") in line
    assert line.endswith("median generations bred per learner 4, 4")


def test_measure_writes_every_table_3_4_output_from_the_committed_inputs(tmp_path, root):
    """A short measurement (200 s of learning, one situation) from the committed winners and
    evolved populations writes what ``--only table3`` or ``--only table4`` alone needs:
    the situations, their per-strategy means, the learners, the learning curve and plots."""
    from dataclasses import replace

    import pandas as pd

    from enn_traffic.experiments.crowds.arena import (
        LEARNING,
        measure,
        saved_inputs,
        strategy_means,
    )

    learning = replace(LEARNING, learning_s=200.0, situations=1)
    measured = measure(tmp_path, saved_inputs(root / "results" / "paper"), learning)
    files = {p.name for p in tmp_path.iterdir()}
    assert {"simultaneous.csv", "simultaneous_situations.csv", "table4_learners.csv",
            "table4_learning.csv", "table4_learning.png", "simultaneous_paths.png",
            "table4_validation_learners.csv"} <= files
    means = pd.read_csv(tmp_path / "simultaneous.csv")
    expected = strategy_means(measured.situations).round(5)
    pd.testing.assert_frame_equal(means.drop(columns="wall_s"), expected, check_dtype=False)
    assert len(pd.read_csv(tmp_path / "table4_learners.csv")) == 4 * 8  # 4 strategies x 8
    assert sorted(pd.read_csv(tmp_path / "table4_learning.csv")["window_start_s"].unique()
                  ) == [0.0, 100.0]


def test_the_papers_winner_is_the_best_chromosome_of_highest_ga_fitness(tmp_path, root):
    """§5.5.1 the paper's way: of the strategy's runs, the ``best.npz`` with the highest
    fitness, the first seed of equals; nothing the crowd showed."""
    from enn_traffic.config.shipped import shipped_scenario
    from enn_traffic.experiments.crowds.arena import paper_winner
    from enn_traffic.experiments.families import ARENA, run_dir
    from enn_traffic.runs.controller import Controller

    scenario = shipped_scenario(ARENA.name(2))
    length = len(Controller.load(root / "results" / "paper" / "controllers" / "table3"
                                 / "strategy2.npz").chromosome)
    for seed, fitness in ((1, 500.0), (2, 900.0), (3, 900.0)):
        folder = run_dir(ARENA, tmp_path, 2, seed)
        folder.mkdir(parents=True)
        Controller.from_scenario(scenario, np.full(length, float(seed)), fitness, 7).save(
            folder / "best.npz")
    np.testing.assert_array_equal(paper_winner(tmp_path, 2, (1, 2, 3)), np.full(length, 2.0))
    np.testing.assert_array_equal(paper_winner(tmp_path, 2, (1,)), np.full(length, 1.0))


def test_table3_says_where_the_papers_winner_differs_from_ours():
    import pandas as pd

    from enn_traffic.experiments.crowds.arena import summary_lines

    situations = pd.DataFrame({
        "strategy": [1, 1, 2, 2], "situation": [0, 1, 0, 1],
        "initial": [0.1] * 4, "winner": [0.02, 0.02, 0.01, 0.03],
        "paper_winner": [0.05, 0.06, 0.02, 0.02]})
    (line,) = summary_lines(situations, pd.DataFrame(), "table3")
    # strategy 1: +0.03, +0.04 (above); strategy 2: +0.01, -0.01 (spans 0)
    assert "strategy 1: 0.055, strategy 2: 0.020" in line
    assert "its rate above ours in 1 of 2 strategies and below in 0" in line


def test_the_ablation_table_pairs_each_arm_with_its_own_first_span_and_the_others():
    import pandas as pd

    from enn_traffic.experiments.ablation import ablation_table, carrier, factor_effects

    rows = []
    for situation, noise in enumerate((0.0, 0.002, -0.002)):
        for start, stopping, after in (("random", "cap", 0.05), ("random", "finish", 0.05),
                                       ("evolved", "cap", 0.01), ("evolved", "finish", 0.01),
                                       ("evolved", "frozen", 0.02)):
            rows.append({"strategy": 1, "situation": situation, "start_population": start,
                         "stopping": stopping, "first_span": 0.1 if start == "random" else 0.01,
                         "early_spans": 0.08 if start == "random" else 0.01,
                         "after": after + noise, "initial_after": 0.08, "winner_after": 0.01,
                         "winner_first": 0.02, "generations_bred": 3, "finished_share": 0.5,
                         "learning_s": 15000.0})
    table = ablation_table(pd.DataFrame(rows))
    random_cap = table[(table["start_population"] == "random") & (table["stopping"] == "cap")]
    assert random_cap["after_minus_first_span"].iloc[0] == pytest.approx(-0.05)
    assert random_cap["after_minus_early_spans"].iloc[0] == pytest.approx(-0.03)
    assert random_cap["reduction_vs_first_span"].iloc[0] == pytest.approx(0.5)
    assert random_cap["after_minus_winner_after"].iloc[0] == pytest.approx(0.04)
    assert random_cap["after_minus_winner_first"].iloc[0] == pytest.approx(0.03)
    assert random_cap["after_minus_winner_after_low"].iloc[0] > 0
    evolved = table[table["start_population"] == "evolved"]
    assert len(evolved) == 3  # cap, finish, frozen
    learnt = evolved[evolved["stopping"] != "frozen"]
    assert (learnt["after_minus_winner_after_low"] <= 0).all()
    assert (learnt["after_minus_winner_after_high"] >= 0).all()
    factors = factor_effects(pd.DataFrame(rows))  # the 2 x 2 alone: not the frozen arm
    assert set(factors["outcome"]) == {"after", "after_minus_first_span",
                                       "after_minus_early_spans"}
    words = carrier(factors)
    assert "start_population random instead of evolved: +0.0400" in words
    assert "raises the rate after learning" in words
    assert "stopping finish instead of cap: +0.0000" in words
    first = factors[(factors["factor"] == "start_population")
                    & (factors["outcome"] == "after_minus_first_span")]
    assert first["effect"].iloc[0] == pytest.approx(-0.05)  # -0.05 against 0.0
