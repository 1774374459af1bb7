"""The GA against PPO and SAC (issue 52): each run spends its budget, chooses its controller
on validation and is scored once on the sealed test situations; the comparison resumes
without running a finished run again; PPO and SAC run through the SB3 adapter."""

import json

import numpy as np
import pandas as pd
import pytest

from enn_traffic.cli import main
from enn_traffic.config.shipped import shipped_scenario
from enn_traffic.core import keys
from enn_traffic.core.errors import InputError
from enn_traffic.experiments.gradient_rl import campaign, policy, protocol, runs, scoring, stats
from enn_traffic.report.stats import holm, t_interval
from enn_traffic.runs.controller import Controller


def test_the_comparisons_keys_are_its_own_and_held_out(monkeypatch):
    monkeypatch.undo()  # the real test keys, as the command reads them
    assert protocol.VALIDATION_KEY in keys.VALIDATION and protocol.TEST_KEY in keys.TEST
    assert protocol.TEST_KEY not in (protocol.FIRST_ROUND_TEST_KEY,
                                     protocol.SECOND_ROUND_TEST_KEY)
    validation, test = scoring.held_out_keys(shipped_scenario("arena_strategy1"))
    assert (len(validation), len(test)) == (32, 64)  # 4 situations a key: 128 and 256
    assert validation[0] == protocol.VALIDATION_KEY and test[0] == protocol.TEST_KEY


def test_no_validation_start_of_the_narrow_track_is_a_test_start():
    """Issue 65: 5 of the narrow track's 64 test starts were validation starts (both drawn
    with replacement from the same 453 poses). Now 128 validation and 256 test situations
    start at as many distinct poses, none shared."""
    from enn_traffic.envs.rangefinder import rangefinder_world

    narrow = shipped_scenario("navigation_narrow")
    validation, test = scoring.held_out_keys(narrow)
    world = rangefinder_world(scoring.scoring_scenario(narrow))
    starts = {name: [scoring.start_of(world.situations(key)[0]) for key in chosen]
              for name, chosen in (("validation", validation), ("test", test))}
    assert len(set(starts["validation"])) == len(starts["validation"]) == 128
    assert len(set(starts["test"])) == len(starts["test"]) == 256
    assert set(starts["validation"]).isdisjoint(starts["test"])
    # the second round's draw, kept for its committed folder: starts repeat and are shared
    old = {"validation_key": keys.VALIDATION.start + 530_000,
           "test_key": protocol.SECOND_ROUND_TEST_KEY, "validation_situations": 32,
           "test_situations": 64}
    old_validation, old_test = scoring.held_out_keys(narrow, old)
    assert old_test == list(range(old["test_key"], old["test_key"] + 64))
    assert len(old_validation) == 32


def test_the_narrow_track_is_scored_from_starts_all_along_it():
    """The narrow track starts at one pose (§5.1): its validation and test situations start
    anywhere on it instead, a different start each; a world with traffic keeps its own."""
    from enn_traffic.envs.rangefinder import rangefinder_world

    narrow = shipped_scenario("navigation_narrow")
    scored = scoring.scoring_scenario(narrow)
    assert scored.track.start_anywhere and scored.track.net == narrow.track.net
    world = rangefinder_world(scored)
    starts = {scoring.start_of(world.situations(key)[0])
              for key in scoring.situation_keys(scored, keys.VALIDATION.start, 64)}
    assert len(starts) > 50  # 64 draws from every 5 m of 1.3 km, facing either way
    arena = shipped_scenario("arena_strategy1")
    assert scoring.scoring_scenario(arena) is arena


@pytest.fixture(autouse=True)
def _no_sealed_keys(monkeypatch):
    """The tests score on design-trial keys: the comparison's test keys are read once, by
    the committed runs."""
    monkeypatch.setattr(protocol, "TEST_KEY", keys.DESIGN_TRIALS.start + 520_000)


def test_a_ga_run_spends_its_budget_and_chooses_on_validation():
    scenario = shipped_scenario("arena_strategy1").with_overrides(
        ga={"population_size": 20, "elite_count": 2})
    result = runs.ga_run(scenario, 40_000, seed=1)
    steps = result.curve["learner_steps"]
    # it learns from every generation that ends within the budget, and from none past it
    assert steps.iloc[-1] == result.learner_steps == result.training_lives.sum() <= 40_000
    assert result.learner_steps > 30_000  # generations of 20 × 4 lives: about 8 k steps
    # a candidate at each checkpoint (every 2,000 steps) a generation reached, and the last
    assert 2 <= len(steps) <= protocol.CHECKPOINTS + 1 and steps.is_monotonic_increasing
    assert result.chosen == int(np.argmax(result.curve["validation_fitness"]))
    assert len(result.test_fitness) == protocol.TEST_SITUATIONS
    assert (result.test_fitness > 0).any()
    # the chosen controller, scored again: its validation score
    again = scoring.chromosome_fitness(scenario, result.controller.chromosome[None],
                                        scoring.held_out_keys(scenario)[0],
                                        protocol.VALIDATION_SITUATIONS).mean()
    assert again == result.curve["validation_fitness"].iloc[result.chosen]


def test_a_policy_and_its_chromosome_score_alike():
    """policy_fitness drives the vector environment; a GA controller's actions through it
    give the GA world's lives (the two scorers agree)."""
    from enn_traffic.envs.rangefinder import action_of, rangefinder_world

    scenario = shipped_scenario("arena_strategy1")
    spec = rangefinder_world(scenario).spec
    chromosome = np.random.default_rng(3).uniform(-1, 1, (1, spec.chromosome_length))
    chosen = [keys.VALIDATION.start, keys.VALIDATION.start + 1]  # 4 situations each
    ga = scoring.chromosome_fitness(scenario, chromosome, chosen, 8)[0]
    env = scoring.policy_fitness(
        scenario, lambda o: action_of(spec.forward(np.repeat(chromosome, len(o), 0), o)),
        chosen, 8)
    assert ga.std() > 0  # situations that tell the scorers apart
    np.testing.assert_allclose(env, ga)


def test_the_command_lines_default_plan_is_the_modules():
    from enn_traffic.cli import build_parser

    default = build_parser().parse_args(["baseline", "navigation_narrow"]).plan
    assert protocol.parse_plan(default) == protocol.PLAN
    assert all(len(search) >= 12 for search in protocol.SEARCH.values())


def test_plans_are_read_and_bad_ones_refused():
    assert protocol.parse_plan("GA:1M:5, ppo:250k:2") == (
        protocol.Planned("GA", 1_000_000, 5), protocol.Planned("PPO", 250_000, 2))
    for bad in ("GA:1M", "DQN:1M:3", "GA:0:3", "GA:1M:0", "GA:lots:3", ""):
        with pytest.raises(InputError):
            protocol.parse_plan(bad)


def test_bad_command_lines_exit_2(capsys):
    assert main(["baseline", "navigation_narrow", "--plan", "GA:1M:5,DQN:1M:3"]) == 2
    assert "--plan" in capsys.readouterr().err
    assert main(["baseline", "sumo_strategy1", "--plan", "GA:1k:1"]) == 2
    assert "sumo_strategy1" in capsys.readouterr().err


def test_the_summary_and_the_differences_carry_the_seeds_spread():
    runs = pd.DataFrame({"scenario": "s", "method": ["GA", "GA", "PPO", "PPO"],
                         "budget_steps": 100, "seed": [1, 2, 1, 2], "test_situations": 3,
                         "test_fitness": [2.0, 4.0, 9.0, 11.0], "learner_steps": 100,
                         "validation_fitness": [5.0, 4.0, 9.0, 12.0],
                         "chosen_at_steps": [50, 100, 100, 100], "wall_s": 1.0})
    curves = pd.DataFrame({"scenario": "s", "method": ["GA"] * 4 + ["PPO"] * 2,
                           "budget_steps": 100, "seed": [1, 1, 2, 2, 1, 2],
                           "learner_steps": [50, 100, 50, 100, 100, 100]})
    table = stats.summary(runs, curves).set_index("method")
    ga = table.loc["GA"]
    assert ga["test_fitness"] == 3.0 and ga["seeds"] == 2 and ga["candidates"] == 2
    assert ga["last_chosen"] == 1 and ga["validation_minus_test"] == 1.5
    # Student's t over 2 seeds: 3 ± t(0.95, 1) · 1.414 / 1.414
    assert ga["seeds_high"] - 3.0 == pytest.approx(3.0 - ga["seeds_low"]) == pytest.approx(
        6.3138, abs=1e-3)
    difference = stats.differences(runs).iloc[0]
    # Welch over 2 + 2 seeds of spread 1.414: 7 ± t(0.95, 2) · 1.414
    assert difference["minus_ga"] == 7.0 and difference["above_ga"] == 1.0
    assert difference["minus_ga_high"] - 7.0 == pytest.approx(2.9200 * np.sqrt(2), abs=1e-3)


def test_holm_adjusts_a_family_of_p_values_step_down():
    """Hand-computed: sorted 0.01, 0.03, 0.04 times 3, 2, 1 is 0.03, 0.06, 0.04; each at
    least the one before: 0.03, 0.06, 0.06. A missing p-value stays out of the family."""
    adjusted = holm(pd.Series([0.01, 0.04, np.nan, 0.03]))
    np.testing.assert_allclose(adjusted, [0.03, 0.06, np.nan, 0.06])
    assert holm(pd.Series([0.5, 0.9])).tolist() == [1.0, 1.0]  # capped at 1


def test_a_scenarios_differences_are_corrected_for_their_family():
    """Two RL methods against one GA budget: a family of 2 per scenario; the simultaneous
    intervals are Welch's at 95% (90% shared by 2), wider than each one's 90%; p-values are
    exact permutation ones (hand-computed: PPO's 3 values are the top 3 of the 6, 1 of the
    20 ways to split them, and so are the GA's on the other side: p = 2/20)."""
    from scipy import stats as scipy_stats

    from enn_traffic.report.stats import permutation_p

    fitness = {"GA": [2.0, 4.0, 3.0], "PPO": [9.0, 11.0, 7.0], "SAC": [3.0, 5.0, 2.0]}
    runs = pd.DataFrame([{"scenario": "s", "method": m, "budget_steps": 100, "seed": i,
                          "test_fitness": f} for m, values in fitness.items()
                         for i, f in enumerate(values)])
    table = stats.differences(runs).set_index("method")
    assert (table["family"] == 2).all()
    for method in ("PPO", "SAC"):
        test = scipy_stats.ttest_ind(fitness[method], fitness["GA"], equal_var=False)
        row = table.loc[method]
        assert row["p_value"] == pytest.approx(permutation_p(fitness[method], fitness["GA"]))
        assert row["minus_ga_low_simultaneous"] == pytest.approx(
            test.confidence_interval(0.95).low)
        assert row["minus_ga_low_simultaneous"] < row["minus_ga_low"]
    assert table.loc["PPO", "p_value"] == pytest.approx(0.1)
    p = sorted(table["p_value"])
    assert sorted(table["p_holm"]) == pytest.approx([2 * p[0], max(2 * p[0], p[1])])


def test_a_longer_run_is_no_continuation_of_the_shorter_one_of_its_seed():
    """Issue 65: a 5 M run of seed 1 replayed the 1 M run of seed 1 for its first 1 M steps.
    Each run's stream now comes from its seed and its budget."""
    scenario = shipped_scenario("arena_strategy1").with_overrides(
        ga={"population_size": 20, "elite_count": 2})
    short, long = (runs.ga_run(scenario, budget, seed=1, test=False)
                   for budget in (4_000, 8_000))
    assert short.training_lives.tolist() != long.training_lives[:len(short.training_lives)]\
        .tolist()
    again = runs.ga_run(scenario, 4_000, seed=1, test=False)
    assert again.training_lives.tolist() == short.training_lives.tolist()


def test_a_folder_of_runs_made_another_way_is_refused(tmp_path, monkeypatch):
    """Runs are skipped by (scenario, method, budget, seed): a folder made with other keys or
    counts would have its rows mixed with new ones, so it is refused."""
    protocol.check_protocol(tmp_path)  # a new folder: its protocol written
    written = json.loads((tmp_path / "protocol.json").read_text())
    assert written["test_key"] == protocol.TEST_KEY
    protocol.check_protocol(tmp_path)  # the same protocol: on
    monkeypatch.setattr(protocol, "VALIDATION_SITUATIONS", 16)
    with pytest.raises(InputError, match="validation_situations"):
        protocol.check_protocol(tmp_path)
    older = tmp_path / "older"
    older.mkdir()
    (older / "comparison.csv").write_text("scenario\n")
    with pytest.raises(InputError, match="no protocol.json"):
        protocol.check_protocol(older)


def test_the_comparison_resumes_without_running_a_finished_run_again(tmp_path, monkeypatch):
    pytest.importorskip("stable_baselines3")
    # a search of two settings each, PPO's with rollouts of 2,048 steps (the zoo's are
    # 65,536): what is checked here is the resume, not the search's size
    monkeypatch.setitem(protocol.SEARCH, "PPO", {
        name: protocol.SEARCH["PPO"][name] | {"n_envs": 8}
        for name in list(protocol.SEARCH["PPO"])[:2]})
    monkeypatch.setitem(protocol.SEARCH, "GA", {
        "P 10": {"population_size": 10}, "P 12": {"population_size": 12}})
    scenario = shipped_scenario("navigation_narrow").with_overrides(
        episode={"max_steps": 300})
    plan = protocol.parse_plan("GA:20k:2,PPO:16k:1")
    campaign.compare([scenario], tmp_path, plan, workers=1, progress=False,
                     search_budget=8_192)
    tuning = pd.read_csv(tmp_path / "tuning.csv")
    assert sorted(tuning["setting"]) == sorted([*protocol.SEARCH["GA"], *protocol.SEARCH["PPO"]])
    assert set(tuning["budget_steps"]) == {8_192}
    first = pd.read_csv(tmp_path / "comparison.csv")
    assert len(first) == 3 and set(first["test_situations"]) == {protocol.TEST_SITUATIONS}
    assert set(first["spin_variance"]) == {scenario.episode.spin_variance}
    ga_setting = campaign.chosen_setting(tuning, scenario.name, "GA")
    assert set(first[first["method"] == "GA"]["setting"]) == {ga_setting}
    ppo = first[first["method"] == "PPO"].iloc[0]
    assert ppo["setting"] == campaign.chosen_setting(tuning, scenario.name, "PPO")
    ppo_setting = protocol.SEARCH["PPO"][ppo["setting"]]
    rollout = ppo_setting["n_envs"] * ppo_setting["n_steps"]
    # whole rollouts within the budget, at least one
    assert ppo["learner_steps"] == max(rollout, 16_000 // rollout * rollout)
    assert (first[first["method"] == "GA"]["learner_steps"] <= 20_000).all()
    assert (tuning[tuning["method"] == "GA"]["learner_steps"] <= 8_192).all()
    # PPO's policy after its last update is a candidate too
    curves = pd.read_csv(tmp_path / "curves.csv")
    assert curves[curves["method"] == "PPO"]["learner_steps"].max() == ppo["learner_steps"]
    # every run's controller is saved, and scores on test what the run's row says
    saved = policy.NumpyPolicy.load(campaign.controller_path(
        tmp_path, scenario.name, "PPO", 16_000, 1))
    test_keys = scoring.held_out_keys(scenario)[1]
    tested = scoring.policy_fitness(scenario, saved, test_keys, protocol.TEST_SITUATIONS)
    assert tested.mean() == pytest.approx(ppo["test_fitness"])
    controller = Controller.load(campaign.controller_path(
        tmp_path, scenario.name, "GA", 20_000, 1))
    ga = first[first["method"] == "GA"].iloc[0]
    assert scoring.chromosome_fitness(scenario, controller.chromosome[None], test_keys,
                                       protocol.TEST_SITUATIONS).mean() == pytest.approx(
        ga["test_fitness"])
    # a second call with one more seed makes that run alone
    campaign.compare([scenario], tmp_path, protocol.parse_plan("GA:20k:3,PPO:16k:1"),
                     workers=1, progress=False, search_budget=8_192)
    second = pd.read_csv(tmp_path / "comparison.csv")
    pd.testing.assert_frame_equal(second.iloc[:3], first)
    assert len(second) == 4 and second.iloc[3]["seed"] == 3
    assert len(pd.read_csv(tmp_path / "situations.csv")) == 4 * protocol.TEST_SITUATIONS
    assert (tmp_path / "comparison.png").stat().st_size > 0
    lives = pd.read_csv(tmp_path / "training_lives.csv").set_index("method")
    assert sorted(lives.index) == ["GA", "PPO"] and (lives["lives"] > 0).all()
    assert (lives["longest_life"] <= 300).all() and (lives["median_life"] > 0).all()


def test_numpy_actor_is_the_sb3_policy_of_ppo_and_sac_after_learning(tmp_path):
    """... and saved and loaded, the same (SAC's clipped mean under gSDE included)."""
    pytest.importorskip("stable_baselines3")
    from stable_baselines3.common.vec_env import VecNormalize

    from enn_traffic.envs.rangefinder import RangefinderVectorEnv
    from enn_traffic.envs.sb3 import sb3_vec_env

    scenario = shipped_scenario("arena_strategy1")
    for method in ("SAC", "PPO"):
        setting = next(iter(protocol.SEARCH[method]))
        settings = protocol.SEARCH[method][setting] | {"learning_starts": 100}
        venv = VecNormalize(sb3_vec_env(RangefinderVectorEnv(scenario, settings["n_envs"])))
        model = runs.rl_model(method, venv, settings, seed=1)
        model.learn(2_000)
        act = policy.numpy_actor(model, venv.obs_rms)
        observation = np.random.default_rng(0).uniform(0, 25, (7, 19)).astype(np.float32)
        expected, _ = model.predict(venv.normalize_obs(observation), deterministic=True)
        np.testing.assert_allclose(act(observation), expected, atol=1e-5)
        act.save(tmp_path / f"{method}.npz")
        loaded = policy.NumpyPolicy.load(tmp_path / f"{method}.npz")
        assert [kind for kind, _, _ in loaded.layers] == [kind for kind, _, _ in act.layers]
        assert ("clip" in [kind for kind, _, _ in act.layers]) == (method == "SAC")
        np.testing.assert_array_equal(loaded(observation), act(observation))


@pytest.mark.full
def test_a_committed_ga_run_of_the_comparison_comes_out_the_same(monkeypatch):
    """A committed GA run at 1 M steps, seed 1, made again with its setting: the same
    generations, the same chosen controller, the same test score as its comparison.csv (the
    sealed keys, read again by the same configuration: nothing is chosen on them). The
    folder is the committed one made under today's protocol."""
    monkeypatch.undo()
    from pathlib import Path

    results = Path(__file__).resolve().parents[2] / "results"
    folders = [folder for folder in (results / "baseline", results / "baseline_round2")
               if (folder / "protocol.json").is_file()
               and json.loads((folder / "protocol.json").read_text()) == protocol.protocol()]
    assert folders, "no committed comparison folder under today's protocol"
    table = pd.read_csv(folders[0] / "comparison.csv")
    ga = table[(table["method"] == "GA") & (table["budget_steps"] == 1_000_000)
               & (table["seed"] == 1)]
    if ga.empty:
        pytest.skip(f"{folders[0].name}: no GA run at 1 M steps yet (the round is under way)")
    committed = ga.iloc[0]
    result = runs.ga_run(shipped_scenario(committed["scenario"]), 1_000_000, seed=1,
                         settings=protocol.SEARCH["GA"][committed["setting"]])
    best = result.curve.iloc[result.chosen]
    assert int(result.learner_steps) == committed["learner_steps"]
    assert int(best["learner_steps"]) == committed["chosen_at_steps"]
    assert result.test_fitness.mean() == pytest.approx(committed["test_fitness"], abs=1e-9)


def test_a_rules_change_of_the_gap_is_a_contrast_of_four_groups_of_seeds():
    """Hand-computed: under the paper's rule PPO − GA = 2 − 10 = −8, under the second
    7 − 11 = −4: the gap changes by +4; its interval is Welch's when three groups have no
    spread (the fourth's alone counts)."""
    from scipy import stats as scipy_stats

    fitness = {("paper", "GA"): [10.0, 10.0, 10.0], ("paper", "PPO"): [2.0, 2.0, 2.0],
               ("second", "GA"): [11.0, 11.0, 11.0], ("second", "PPO"): [5.0, 7.0, 9.0]}
    runs = pd.DataFrame([{"scenario": name, "method": method, "budget_steps": 100,
                          "seed": i, "test_fitness": f}
                         for (name, method), values in fitness.items()
                         for i, f in enumerate(values)])
    row = stats.rule_changes(runs, pairs=(("paper", "second"),)).iloc[0]
    assert (row["minus_ga_paper_rule"], row["minus_ga_second_rule"]) == (-8.0, -4.0)
    assert row["change"] == pytest.approx(4.0)
    half = scipy_stats.t.ppf(0.95, 2) * scipy_stats.sem(fitness[("second", "PPO")])
    assert (row["change_low"], row["change_high"]) == pytest.approx((4.0 - half, 4.0 + half))
    assert (row["above_ga_paper_rule"], row["above_ga_second_rule"]) == (0.0, 0.0)
    assert row["family"] == 1 and row["change_low_simultaneous"] == row["change_low"]
    assert stats.rule_changes(runs, pairs=(("paper", "other"),)).empty


def test_seeds_piled_at_the_cap_give_a_point_not_a_missing_interval():
    """Every seed of both methods at the step cap: the difference is exactly 0, p = 1 (the
    t-test's is undefined), and the seeds' interval is the cap itself."""
    runs = pd.DataFrame([{"scenario": "s", "method": method, "budget_steps": 100, "seed": i,
                          "test_fitness": 20_000.0}
                         for method in ("GA", "SAC") for i in range(3)])
    row = stats.differences(runs).iloc[0]
    assert row[["minus_ga", "minus_ga_low", "minus_ga_high", "minus_ga_low_simultaneous",
                "minus_ga_high_simultaneous"]].tolist() == [0.0] * 5
    assert row["p_value"] == 1.0 and row["p_holm"] == 1.0 and row["above_ga"] == 0.5
    assert t_interval(runs["test_fitness"].to_numpy()) == (20_000.0, 20_000.0)


@pytest.mark.full
def test_a_gradient_rl_run_leaves_nothing_in_the_temporary_folder(tmp_path, monkeypatch):
    """SB3's own logger made an empty SB3-<time> folder in TMPDIR for every run of the
    comparison (a fresh probe found four after one baseline command), and torch its compiler
    cache folder, torchinductor_<user> (found by the next probe)."""
    pytest.importorskip("stable_baselines3")
    import tempfile

    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))
    # set first, so that monkeypatch unsets what rl_run sets for the rest of the process
    monkeypatch.setenv("TORCHINDUCTOR_CACHE_DIR", "")
    monkeypatch.delenv("TORCHINDUCTOR_CACHE_DIR")
    monkeypatch.setenv("ENN_TRAFFIC_CACHE", str(tmp_path / "cache"))
    scenario = shipped_scenario("arena_strategy1")
    setting = next(iter(protocol.SEARCH["PPO"]))
    settings = protocol.SEARCH["PPO"][setting]
    runs.rl_run(scenario, "PPO", settings, settings["n_envs"] * settings["n_steps"], seed=1,
                test=False)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["cache"]


def test_a_plan_of_the_ga_alone_finishes_without_a_verdict(tmp_path, monkeypatch):
    """A comparison of the GA alone (no gradient-RL method installed or asked for) has no
    difference to state: it finishes with its tables and no verdict facts (its facts step
    raised IndexError after every run was done, exit 1)."""
    monkeypatch.setitem(protocol.SEARCH, "GA", {
        "P 10": {"population_size": 10}, "P 12": {"population_size": 12}})
    scenario = shipped_scenario("navigation_narrow").with_overrides(episode={"max_steps": 100})
    campaign.compare([scenario], tmp_path, protocol.parse_plan("GA:2k:1"), workers=1,
                     progress=False, search_budget=2_000)
    assert len(pd.read_csv(tmp_path / "comparison.csv")) == 1
    assert pd.read_csv(tmp_path / "comparison_differences.csv").empty
    assert not list(tmp_path.rglob("verdict*.json"))
