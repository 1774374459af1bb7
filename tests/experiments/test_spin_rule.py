"""The comparison's second spin rule (issue 65): centre-keeping controllers without learning,
and the rule chosen on validation situations where none of their lives is ruled a spin."""

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from enn_traffic.config import load_scenario
from enn_traffic.config.shipped import shipped_scenario
from enn_traffic.envs.rangefinder import rangefinder_world
from enn_traffic.experiments.gradient_rl import campaign, protocol, scoring, spin_rule
from enn_traffic.sim.world import SituationResults

ROOT = Path(__file__).resolve().parents[2]
COMMITTED = ROOT / spin_rule.FOLDER / "spin_rule.csv"


def test_centre_keeping_steers_towards_the_side_with_more_room():
    """Beams are read right to left: 9 on the right at 5 m, the middle one, 9 on the left at
    15 m; range 25 m, gain 1: u = (15 - 5) / 25 = 0.4, the action (-0.4, 0.4); the mirror
    image steers the other way, and a large gain is clipped to full lock."""
    observation = np.array([[5.0] * 9 + [20.0] + [15.0] * 9], dtype=np.float32)
    np.testing.assert_allclose(spin_rule.centre_keeping(1.0, 25.0)(observation),
                               [[-0.4, 0.4]], rtol=1e-6)
    np.testing.assert_allclose(spin_rule.centre_keeping(1.0, 25.0)(observation[:, ::-1]),
                               [[0.4, -0.4]], rtol=1e-6)
    np.testing.assert_array_equal(spin_rule.centre_keeping(10.0, 25.0)(observation),
                                  [[-1.0, 1.0]])


def test_the_papers_rule_rules_centre_keeping_a_spin_and_the_second_rule_does_not():
    """On 16 of the narrow track's validation situations: under 64 m² most centre-keeping
    lives end as a spin (the double bend), under 40 m² none does, and they live longer."""
    narrow = shipped_scenario("navigation_narrow")
    validation, _ = scoring.held_out_keys(narrow)
    table = spin_rule.spin_table(scoring.scoring_scenario(narrow), validation[:16],
                                 candidates=(64.0, 40.0), gains=(1.0,)).set_index(
        "spin_variance")
    assert table.loc[64.0, "spins"] >= 8
    assert table.loc[40.0, "spins"] == 0
    assert table.loc[40.0, "median_steps"] > table.loc[64.0, "median_steps"]
    assert spin_rule.chosen_variance(table.reset_index()) == 40.0


def test_from_the_registered_ids_one_start_centre_keeping_spins_only_under_the_papers_rule():
    """docs/envs.md: from NavigationNarrow-v0's one start, centre keeping is ruled a spin at
    the first turn under 64 m² (within the first 100 steps), and drives on under 40 m²."""
    lives = {name: scoring.policy_lives(shipped_scenario(name),
                                         spin_rule.centre_keeping(1.0, 25.0),
                                         [protocol.VALIDATION_KEY]).iloc[0]
             for name in ("navigation_narrow", "navigation_narrow_spin40")}
    assert lives["navigation_narrow"]["outcome"] == "spin"
    assert lives["navigation_narrow"]["steps"] < 100
    assert lives["navigation_narrow_spin40"]["outcome"] != "spin"
    assert lives["navigation_narrow_spin40"]["steps"] > 1000


def test_the_choice_is_the_largest_candidate_without_a_spin():
    table = pd.DataFrame({"spin_variance": [64.0, 64.0, 48.0, 48.0, 32.0, 32.0],
                          "gain": [1, 2] * 3, "spins": [5, 0, 0, 1, 0, 0]})
    assert spin_rule.chosen_variance(table) == 32.0
    with pytest.raises(ValueError, match="every candidate"):
        spin_rule.chosen_variance(table.assign(spins=1))


def test_the_shipped_second_rule_is_the_committed_choice():
    """``navigation_narrow_spin40`` is the narrow track with the spin_variance that the
    committed table chose (validation situations only), and nothing else changed."""
    table = pd.read_csv(COMMITTED)
    assert set(table["first_key"]) == {scoring.held_out_keys(
        shipped_scenario("navigation_narrow"))[0][0]}
    assert (table["situations"] == protocol.VALIDATION_SITUATIONS).all()
    second = load_scenario(ROOT / "scenarios" / "navigation_narrow_spin40.toml")
    paper = shipped_scenario("navigation_narrow")
    assert second.episode.spin_variance == spin_rule.chosen_variance(table)
    assert second.model_copy(update={"name": paper.name, "description": paper.description,
                                     "source": paper.source}).with_overrides(
        episode={"spin_variance": paper.episode.spin_variance}) == paper


@pytest.mark.full
def test_the_committed_spin_rule_table_comes_out_the_same(tmp_path):
    pd.testing.assert_frame_equal(spin_rule.write(tmp_path), pd.read_csv(COMMITTED))


def test_a_right_angle_bend_is_a_spin_under_the_papers_rule_and_not_under_40():
    """Hand-computed: 49 positions 1 m apart (4.9 s at 10 m/s), 25 along x then 24 along y:
    each axis's population variance is 62.5 m² (half the points spread over 24 m, half at
    its end), under 64 and over 40."""
    from enn_traffic.sim.rules import _small_spread

    bend = np.array([(i, 0.0) for i in range(25)] + [(24.0, j) for j in range(1, 25)])
    assert bend[:, 0].var() == pytest.approx(62.516, abs=1e-3)
    assert _small_spread(bend, 64.0) and not _small_spread(bend, 40.0)
    straight = np.column_stack([np.arange(49.0), np.zeros(49)])
    assert not _small_spread(straight, 64.0)  # 200 m² along the road


@pytest.mark.parametrize(("radius", "paper", "second"),
                         [(3.0, True, True), (8.5, True, True), (10.0, True, False),
                          (12.0, False, False)])
def test_circling_is_still_a_spin_under_40_up_to_a_radius_of_about_8_5_m(radius, paper, second):
    """What the second rule lets through: a vehicle circling at 1 m a step with a radius up
    to 8.5 m is a spin under both rules (a full turn within the window at 7.8 m: variance
    r²/2); 9–11.5 m only under the paper's; 12 m under neither."""
    from enn_traffic.sim.rules import _small_spread

    angle = np.arange(49) / radius
    circle = np.column_stack([radius * np.cos(angle), radius * np.sin(angle)])
    assert (_small_spread(circle, 64.0), _small_spread(circle, 40.0)) == (paper, second)


def test_a_straight_life_travels_a_metre_a_step():
    """Steering 0 (both outputs alike): each step carries the learner speed × dt = 1 m, so
    a life of n steps covers n − 1 m between its first and last recorded positions, and its
    last 50 positions span at least 49 m / √2 on one axis."""
    narrow = scoring.scoring_scenario(shipped_scenario("navigation_narrow_spin40"))
    validation, _ = scoring.held_out_keys(narrow)
    lives = scoring.policy_lives(narrow, lambda o: np.zeros((len(o), 2), np.float32),
                                  validation, 8, tail=50)
    assert (lives["outcome"] == "collision").all()
    np.testing.assert_allclose(lives["distance"], lives["steps"] - 1, rtol=1e-6)
    long = lives[lives["steps"] > 50]
    assert len(long) and (long["tail_extent"] >= 49 / np.sqrt(2) - 1e-6).all()


def test_travel_scores_a_runs_controller_under_its_rule_and_the_other(tmp_path):
    """A committed GA run's controller (round 3, 40 m², 1 M, seed 1), driven by travel: its
    fitness under its own rule and under the pair's other rule are the GA world's on the
    same validation situations (the comparison's scorer: on float32 readings its long lives
    part from the GA's, 758.25 against 759.5 here), and they differ (it drives the bends the
    paper's rule calls spins), so the two columns cannot be swapped unnoticed. Run again, it
    keeps the row it wrote. From the start it trained from it lives as the GA's world says."""
    import shutil

    from enn_traffic.runs.controller import Controller

    second = scoring.scoring_scenario(shipped_scenario("navigation_narrow_spin40"))
    paper = scoring.scoring_scenario(shipped_scenario("navigation_narrow"))
    path = campaign.controller_path(tmp_path, second.name, "GA", 1_000_000, 1)
    path.parent.mkdir()
    shutil.copy(campaign.controller_path(ROOT / spin_rule.FOLDER, second.name, "GA",
                                         1_000_000, 1), path)
    pd.DataFrame([{"scenario": second.name, "method": "GA", "budget_steps": 1_000_000,
                   "seed": 1}]).to_csv(tmp_path / "comparison.csv", index=False)
    row = spin_rule.travel(tmp_path, situations=4).iloc[0]
    chromosome = Controller.load(path).chromosome[None]
    validation, _ = scoring.held_out_keys(second)
    for scenario, column in ((second, "fitness"), (paper, "other_rule_fitness")):
        assert row[column] == pytest.approx(
            scoring.chromosome_fitness(scenario, chromosome, validation, 4).mean())
    assert row["fitness"] > 10 * row["other_rule_fitness"]
    from_start = rangefinder_world(shipped_scenario(second.name)).evaluate(chromosome, 7)
    assert row["training_start_fitness"] == SituationResults.lifetime_fitness(
        from_start.steps, from_start.outcome)[0, 0]
    assert pd.read_csv(tmp_path / "travel.csv").shape[0] == 1
    path.unlink()  # run again, travel keeps the row it has: it loads no controller
    pd.testing.assert_series_equal(spin_rule.travel(tmp_path, situations=4).iloc[0], row)


def test_a_lower_cap_scores_a_life_past_it_as_the_cap():
    """Hand-computed: under a cap of 1,000 a crash at 700 keeps 700, a spin at 80 scores 0,
    a crash at 5,000, a spin at 3,000 and a life capped at 20,000 all score 1,000."""
    lives = pd.DataFrame({"steps": [700, 80, 5000, 3000, 20000],
                          "fitness": [700.0, 0.0, 5000.0, 0.0, 20000.0]})
    assert spin_rule.capped(lives, 1000).tolist() == [700, 0, 1000, 1000, 1000]


def test_a_life_that_turns_round_at_a_dead_end_meets_one_twice():
    """The narrow track's dead ends are its network's nodes n0 (−2, −20) and n27 (−210, −30)
    (sumo_nets/track_narrow.nod.xml). Hand-made lives along x with ends at 0 and 100: from
    5 to 100 and back to 0 meets an end twice (its start beside one not counted); from 50 to
    100 once; from 30 to 70 never."""
    ends = spin_rule.dead_ends(shipped_scenario("navigation_narrow"))
    np.testing.assert_allclose(ends, [[-2, -20], [-210, -30]])
    ends = np.array([[0.0, 0.0], [100.0, 0.0]])

    def along(*xs):
        return np.stack([np.concatenate(xs), np.zeros(sum(map(len, xs)))], axis=1)

    assert spin_rule.end_visits(along(np.arange(5, 101), np.arange(99, -1, -1)), ends) == 2
    assert spin_rule.end_visits(along(np.arange(50, 101)), ends) == 1
    assert spin_rule.end_visits(along(np.arange(30, 71)), ends) == 0
