"""Tables 3–4's protocol (paper §5.5): ranking candidates, the evolved population, the
reduction's interval."""

import numpy as np
import pytest
from conftest import two_cars


@pytest.fixture
def world(tmp_path, root):
    return two_cars(tmp_path, root, (20.0, 50.0), (40.0, 50.0), 180.0)


def test_evolved_population_puts_the_ranked_candidates_first_without_repeats():
    from enn_traffic.experiments.simultaneous import _evolved_population

    a, b, c, d = (np.full(3, float(k)) for k in range(4))
    population = _evolved_population(np.stack([a, b]), np.stack([b, c, b, d]), size=3)
    np.testing.assert_array_equal(population, np.stack([a, b, c]))


def test_reduction_interval_follows_the_situations():
    import pandas as pd

    from enn_traffic.experiments.simultaneous import reduction_interval

    rng = np.random.default_rng(0)
    steady = pd.DataFrame({"strategy": [1, 1, 1, 2, 2], "initial": [1, 1, 1, 2, 2],
                           "population": [0.5, 0.5, 0.5, 0, 0]})
    assert reduction_interval(steady, "population", rng) == pytest.approx((0.75, 0.75))
    varied = pd.DataFrame({"strategy": [1] * 6, "initial": [1.0] * 6,
                           "population": [0.0, 0.0, 0.0, 0.4, 0.4, 0.4]})  # 80% on average
    low, high = reduction_interval(varied, "population", rng)
    assert 0.6 < low < 0.8 < high < 1.0


def test_ranking_keeps_what_validation_showed_of_each_candidate(world):
    """The winner of §5.5.1 is the candidate that lost fewest lives on the validation
    situations; each candidate's steps and lives lost there are kept as evidence for §5.5.2."""
    from enn_traffic.experiments import simultaneous

    straight = np.zeros(world.spec.chromosome_length)
    circling = straight.copy()
    circling[-1] = 1.0  # spins out (see the test above)
    candidates = np.stack([straight, circling])
    ranked, evidence = simultaneous._ranked(world, candidates)
    lost = {}
    for genes in world.spec.in_source_layout(candidates):  # the layout the arena drives
        runs = [simultaneous._broadcast(world, genes, s, simultaneous.VALIDATION_KEY)[0]
                for s in range(simultaneous.VALIDATION_SITUATIONS)]
        lost[genes.tobytes()] = sum(int(r.collisions.sum() + r.spins.sum()) for r in runs)
        assert evidence.steps[genes.tobytes()] == sum(r.vehicle_steps for r in runs)
        assert evidence.losses[genes.tobytes()] == lost[genes.tobytes()]
    assert len(set(lost.values())) == 2
    assert [lost[row.tobytes()] for row in world.spec.in_source_layout(ranked)] == sorted(
        lost.values())


def test_tables_3_and_4_and_their_summary_lines():
    import pandas as pd

    from enn_traffic.experiments.simultaneous import rates_table, summary_lines

    measured = pd.DataFrame({  # two strategies' mean rates per span
        "strategy": [1, 2], "initial": [0.10, 0.05], "initial_next": [0.08, 0.04],
        "winner": [0.02, 0.01], "winner_next": [0.02, 0.01], "population": [0.02, 0.02],
        "pooled": [0.04, 0.01], "simulated_s": [100.0, 100.0], "wall_s": [1.0, 1.0]})
    situations = measured.drop(columns=["simulated_s", "wall_s"])
    table4 = rates_table(measured, "population")
    assert list(table4["after_collisions_per_s"]) == [0.02, 0.02]
    assert list(table4["initial_collisions_per_s"]) == [0.10, 0.05]
    (line,) = summary_lines(table4, measured, situations, "population", "table4", "population")
    # like for like: 1 - 0.02/0.08 = 75%, 1 - 0.02/0.04 = 50% -> 62%; winner driving on:
    # 75% and 75%; one pooled chromosome: 50% and 75% -> 62%; from the first span: 80% and
    # 60% -> 70%
    assert line.startswith("table4 (population): like for like")
    assert ("mean reduction 62%, where the winner driving on without learning reaches 75% and "
            "all driving one pooled chromosome after learning 62%") in line
    assert line.index("62%") < line.index("mean reduction 70%")
    (line,) = summary_lines(rates_table(measured, "winner"), measured, situations, "winner",
                            "table3", "winner")
    # 1 - 0.02/0.10 = 80%, 1 - 0.01/0.05 = 80%
    assert "strategy 1: 0.100 -> 0.020" in line and "mean reduction 80%" in line
