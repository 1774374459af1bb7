"""The committed results are today's code's (issue 26, "results tied to code"): an experiment
rerun from scratch at its full settings writes the committed table byte for byte, and the
committed controllers drive as the committed tables say.

Two tiers (docs/design.md, "Tests"): ``pytest`` checks a sample of every committed table (a
run's first generations, one row, one family among SUMO traffic) in seconds; the tests marked
``full`` check them whole (``pytest -m full``, minutes; ``.ci/run`` runs both)."""

import numpy as np
import pandas as pd
import pytest

from enn_traffic.config.shipped import shipped_scenario
from enn_traffic.experiments import EXPERIMENTS
from enn_traffic.experiments.families import ARENA, CITY, SUMO
from enn_traffic.experiments.lanekeeping import TEST_KEY, road_world
from enn_traffic.experiments.study import Study
from enn_traffic.runs.controller import Controller

FULL = pytest.mark.full


def full(*values, id: str):
    """A parameter of the ``full`` tier."""
    return pytest.param(*values, id=id, marks=FULL)


@pytest.mark.parametrize("name, seed, column, threshold", [
    ("navigation_narrow", 2, "passed_A_generation", 100),
    ("navigation_wide", 2, "capped_generation", None)], ids=["fig7", "fig8"])
def test_the_first_generations_of_a_navigation_run_give_its_row(name, seed, column, threshold,
                                                               tmp_path, root):
    """A seed's Fig. 7 or Fig. 8 run evolved again from scratch up to the generation of a
    committed column (the first to pass location A; the first whose best life is capped):
    that generation is the committed one (the whole tables: the ``full`` tier)."""
    from enn_traffic.experiments.common import first_generation, run_or_reuse

    paper = root / "results" / "paper"
    row = pd.read_csv(paper / f"{'fig7' if threshold else 'fig8'}.csv").set_index("seed")
    generation = int(row.loc[seed, column])
    scenario = shipped_scenario(name)
    scenario = scenario.with_overrides(seed=seed, ga={"generations": generation + 1})
    table = run_or_reuse(scenario, tmp_path, progress=False)
    threshold = threshold or scenario.episode.max_steps
    assert first_generation(table, threshold) == generation
    assert first_generation(table.iloc[:-1], threshold) != generation


@FULL
def test_todays_code_writes_the_committed_navigation_tables(tmp_path, root):
    """Figs. 7, 8 and 9 rerun from scratch at full settings in one study (Fig. 9's 19 beams
    are Fig. 7's runs): every committed table, byte for byte."""
    study = Study(tmp_path, progress=False)
    for name in ("fig7", "fig8", "fig9"):
        EXPERIMENTS[name](study)
    for table in ("fig7.csv", "fig8.csv", "fig9.csv", "fig9_runs.csv"):
        committed = root / "results" / "paper" / table
        assert (tmp_path / table).read_text() == committed.read_text(), table


@pytest.mark.parametrize("family, strategy", [pytest.param(ARENA, 1, id="arena"),
                                              pytest.param(SUMO, 2, id="sumo"),
                                              full(CITY, 4, id="city")])
def test_the_first_generation_of_a_fig11_run_gives_its_row(family, strategy, tmp_path, root):
    """Fig. 11's run of seed 1, its first generation evolved again: the committed row's
    first best and mean fitness, and that best chromosome's fitness on the test situations
    (a whole run is an hour's compute; its first generation is seconds)."""
    from enn_traffic.experiments.choosing import mean_fitness
    from enn_traffic.experiments.common import run_or_reuse
    from enn_traffic.runs.evaluate import EVALUATION_KEY
    from enn_traffic.runs.run import RunOutputs

    paper = root / "results" / "paper"
    table = pd.read_csv(paper / family.folder / "fig11.csv")
    row = table[(table["strategy"] == strategy) & (table["seed"] == 1)].iloc[0]
    scenario = family.scenario(strategy).with_overrides(
        seed=1, ga={**dict(family.ga), "generations": 1})
    generation = run_or_reuse(scenario, tmp_path, progress=False).iloc[0]
    assert (generation["best_fitness"], generation["mean_fitness"]) == pytest.approx(
        (row["first_best"], row["first_mean"]), rel=5e-6)  # 6 significant digits
    champion = RunOutputs.load(tmp_path).champions[:1]
    on_test = mean_fitness(Study(tmp_path), family, champion, strategy, EVALUATION_KEY)[0]
    assert on_test == pytest.approx(row["first_held_out"], rel=5e-6)


@pytest.mark.parametrize("road", ["tight sine (6 m, 70 m)", "circle, radius 35 m"])
def test_a_committed_lane_keeping_controller_drives_its_table_row(road, root):
    """The drawn-road controller of seed 2 on a road of lane_keeping.csv, with the noisy
    camera: the same steps in the lane and the same mean offset as the committed row."""
    paper = root / "results" / "paper"
    table = pd.read_csv(paper / "lane_keeping.csv")
    row = table[(table["trained_on"] == "lane_keeping_mixed") & (table["seed"] == 2)
                & (table["road"] == road) & (table["noise_m"] == 0.1)].iloc[0]
    controller = Controller.load(paper / "controllers" / "lane_keeping"
                                 / "lane_keeping_mixed_seed2.npz")
    world = road_world("lane_keeping_mixed", road, 0.1)
    steps, _, offset = world.offsets(controller.chromosome, TEST_KEY)[0]
    assert (steps, round(offset, 3)) == (row["steps_in_lane"], row["mean_abs_offset_m"])


@FULL
def test_committed_table1_controllers_keep_the_pattern_on_unseen_traffic(root):
    """Each committed Table 1 specialist on 200 situations of traffic seed 5000, which no
    training and no choice of controller drew (the scenarios' own seed is 1000): every entry
    of the committed ``table1_seed5000_matrix.csv`` (the README's ``evaluate`` command), and
    the paper's diagonal above the rest of every row."""
    from enn_traffic.runs.evaluate import evaluate_batch, fitness_matrix

    paper = root / "results" / "paper"
    folder = paper / "controllers" / "table1"
    controllers = {f"strategy{s}": Controller.load(folder / f"strategy{s}.npz")
                   for s in ARENA.strategies}
    scenarios = [shipped_scenario(f"arena_strategy{s}").with_overrides(traffic={"seed": 5000})
                 for s in ARENA.strategies]
    matrix = fitness_matrix(evaluate_batch(controllers, scenarios, 200, "local", None,
                                           progress=False))
    committed = pd.read_csv(paper / "table1_seed5000_matrix.csv", index_col=0)
    # the CSV keeps 6 significant digits
    pd.testing.assert_frame_equal(matrix, committed, check_names=False, rtol=5e-6)
    for row, own in enumerate(np.diag(matrix.to_numpy())):
        assert own > np.delete(matrix.to_numpy()[row], row).max(), matrix


@pytest.mark.parametrize("rows", [pytest.param([1], id="first row"),
                                  full(ARENA.strategies, id="every row")])
def test_the_committed_table1_controllers_drive_every_entry_of_their_table(rows, root):
    """Each committed specialist on each strategy's 200 test situations: the committed
    Table 1, entry for entry (its first row; the ``full`` tier: every row)."""
    from enn_traffic.experiments.choosing import fitness_on_test_traffic

    paper = root / "results" / "paper"
    table = pd.read_csv(paper / "table1.csv").set_index("training_strategy")
    study = Study(paper)
    for trained in rows:
        controller = Controller.load(paper / "controllers" / "table1" / f"strategy{trained}.npz")
        for deployed in ARENA.strategies:
            fitness = fitness_on_test_traffic(study, ARENA, controller.chromosome, deployed)
            assert round(fitness, 1) == table.loc[trained, f"deploy_{deployed}"], (trained,
                                                                                  deployed)


@pytest.mark.parametrize("family, strategy", [pytest.param(SUMO, 2, id="sumo"),
                                              full(CITY, 3, id="city")])
def test_a_committed_sumo_table1_controller_drives_its_table_entry(family, strategy, root):
    """A specialist among SUMO traffic (crossing flows; Cologne's stop-and-go), replayed on
    its strategy's 10 test situations: the committed diagonal entry of its ``table1.csv``."""
    from enn_traffic.experiments.choosing import fitness_on_test_traffic

    paper = root / "results" / "paper"
    entry = pd.read_csv(paper / family.folder / "table1.csv").set_index("training_strategy")
    controller = Controller.load(paper / "controllers" / family.folder / "table1"
                                 / f"strategy{strategy}.npz")
    fitness = fitness_on_test_traffic(Study(paper), family, controller.chromosome, strategy)
    assert round(fitness, 1) == entry.loc[strategy, f"deploy_{strategy}"]


@pytest.mark.parametrize("family, strategies", [
    pytest.param(ARENA, None, id="arena"), pytest.param(SUMO, [1], id="sumo strategy 1"),
    full(SUMO, None, id="sumo"), full(CITY, None, id="city")])
def test_the_committed_table2_controller_drives_its_last_row(family, strategies, root):
    """Table 2's last controller, trained on all four strategies with the incremental
    network, on each strategy's test situations (200 in the arena, 10 among SUMO traffic):
    the committed last row, entry for entry, and its average (a sample: one entry)."""
    from enn_traffic.experiments.choosing import fitness_on_test_traffic

    paper = root / "results" / "paper"
    last_row = pd.read_csv(paper / family.folder / "table2.csv").iloc[-1]
    controller = Controller.load(paper / "controllers" / family.folder / "table2"
                                 / "last_iteration.npz")
    study = Study(paper)
    strategies = strategies or family.strategies
    fitness = [fitness_on_test_traffic(study, family.incremental(), controller.chromosome, s)
               for s in strategies]
    # the table holds one decimal, as pandas rounds it
    for strategy, value in zip(strategies, fitness, strict=True):
        assert value == pytest.approx(last_row[f"strategy_{strategy}"], abs=0.05 + 1e-9)
    if len(strategies) == len(family.strategies):
        assert np.mean(fitness) == pytest.approx(last_row["average"], abs=0.05 + 1e-9)


@pytest.mark.parametrize("family, strategy", [full(SUMO, 3, id="sumo"),
                                              full(SUMO, 2, id="sumo crossing flows"),
                                              pytest.param(CITY, 2, id="city")])
def test_a_committed_controller_drives_its_closed_loop_rows(family, strategy, root):
    """A strategy's committed Table 1 controller on its test situations, traffic replayed and
    in closed loop (each SUMO start in a fresh process: the crossing flows' closed loop
    depends on it): every episode's two lifetimes in the committed ``closed_loop.csv``."""
    from enn_traffic.runs.evaluate import EVALUATION_KEY
    from enn_traffic.sim.world import make_world

    paper = root / "results" / "paper"
    table = pd.read_csv(paper / family.folder / "closed_loop.csv")
    rows = table[table["strategy"] == strategy]
    controller = Controller.load(paper / "controllers" / family.folder / "table1"
                                 / f"strategy{strategy}.npz")
    test = family.scenario(strategy, family.test_situations)
    for mode, column in (("replay", "replay_steps"), ("closed-loop", "closed_loop_steps")):
        world = make_world(test.with_overrides(traffic={"mode": mode}))
        steps = world.evaluate(controller.chromosome[None, :], EVALUATION_KEY).steps[0]
        assert steps.tolist() == rows[column].tolist(), mode


@pytest.mark.parametrize("strategy", [1, 2, 3, 4])
def test_committed_arena_crowd_files_drive_their_first_situation(strategy, root):
    """Tables 3-4 in the arena, a strategy's first situation driven again from the committed
    files (the winner, the evolved population): every rate of the committed
    ``simultaneous_situations.csv`` row, every learner's ``table4_learners.csv`` row
    (generations bred, lives, chromosomes tried), its learning windows, and each vehicle's
    committed controller after learning."""
    from enn_traffic.experiments.crowds.arena import LEARNING, saved_inputs, situation_rates
    from enn_traffic.sim.arena import ArenaWorld

    paper = root / "results" / "paper"
    controllers = paper / "controllers"

    def first(name: str) -> pd.DataFrame:
        table = pd.read_csv(paper / name)
        return table[(table["strategy"] == strategy) & (table["situation"] == 0)]

    world = ArenaWorld(shipped_scenario(ARENA.name(strategy)))
    winner, evolved = saved_inputs(paper)[strategy]
    result = situation_rates(world, 0, world.spec.in_source_layout(winner)[0],
                             world.spec.in_source_layout(evolved), LEARNING)
    row = first("simultaneous_situations.csv").iloc[0]
    # the CSV keeps 6 significant digits
    assert result.rates == pytest.approx(row[list(result.rates)].to_dict(), rel=5e-6,
                                         abs=1e-12)
    learners = first("table4_learners.csv").drop(columns=["strategy", "situation"])
    assert learners.to_dict("records") == result.learners
    for vehicle, genes in enumerate(result.controllers):
        committed = Controller.load(controllers / "table4"
                                    / f"strategy{strategy}_vehicle{vehicle}.npz")
        np.testing.assert_array_equal(genes, committed.chromosome)


@pytest.mark.parametrize("strategy", [1, full(2, id="2"), full(3, id="3"), full(4, id="4")])
def test_committed_ablation_files_drive_their_first_situation(strategy, root):
    """Table 4's ablation, a strategy's first situation driven again from the committed
    winner and evolved population: every arm's row of ``table4_ablation_situations.csv``
    (its first span, the span after learning, the other arms over it, the learners)."""
    from enn_traffic.experiments.ablation import ABLATION, situation_arms
    from enn_traffic.experiments.crowds.arena import saved_inputs
    from enn_traffic.sim.arena import ArenaWorld

    paper = root / "results" / "paper"
    committed = pd.read_csv(paper / "table4_ablation_situations.csv")
    committed = committed[(committed["strategy"] == strategy) & (committed["situation"] == 0)]
    world = ArenaWorld(shipped_scenario(ARENA.name(strategy)))
    winner, evolved = saved_inputs(paper)[strategy]
    rows, _ = situation_arms(world, 0, world.spec.in_source_layout(winner)[0],
                             world.spec.in_source_layout(evolved), ABLATION)
    driven = pd.DataFrame(rows).round(5)
    columns = list(driven.columns)
    pd.testing.assert_frame_equal(committed[columns].reset_index(drop=True), driven,
                                  check_dtype=False)


@pytest.mark.full
def test_committed_departures_drive_their_first_situation(root):
    """The authors' last rules, situation 0 driven again under every variant: its rows of
    ``departures_situations.csv`` (the learning's first span, spans 2–11, after learning, the
    initial drivers' first span)."""
    from enn_traffic.experiments.departures import situation_rows

    committed = pd.read_csv(root / "results" / "paper" / "departures_situations.csv")
    driven = pd.DataFrame(situation_rows(0)).round(5)
    pd.testing.assert_frame_equal(committed[committed["situation"] == 0].reset_index(drop=True),
                                  driven, check_dtype=False)


@pytest.mark.full
def test_committed_authors_rules_drive_their_first_situation(root):
    """The authors' set-up's three rules, situation 0 driven again under every variant: its
    rows of ``authors_rules_situations.csv``."""
    from enn_traffic.experiments.authors_rules import situation_rows

    committed = pd.read_csv(root / "results" / "paper" / "authors_rules_situations.csv")
    driven = pd.DataFrame(situation_rows(0)).round(5)
    pd.testing.assert_frame_equal(committed[committed["situation"] == 0].reset_index(drop=True),
                                  driven, check_dtype=False)


@pytest.mark.parametrize("family, strategy", [pytest.param(SUMO, 3, id="sumo"),
                                              full(CITY, 1, id="city")])
def test_committed_sumo_crowd_files_drive_their_first_situation(family, strategy, root):
    """Table 4 among SUMO traffic, a strategy's first situation's learning driven again from
    the committed files (the Table 1 controller as winner, the evolved population): every
    learner's ``table4_learners.csv`` row (generations bred, lives, chromosomes tried), the
    collision rates of the committed ``crowd_situations.csv`` row while learning and after
    it, the SSM conflict rate after it (SUMO in a fresh process, as measured), and each
    learner's committed controller after learning. (The initial drivers' and the winner's
    arms, driven the same way, are left to the reproduction: 2 of the 3 arms' SUMO time.)"""
    from enn_traffic.experiments.crowds.sumo import SUMO_LEARNING, crowd_world, learn_together

    paper = root / "results" / "paper"
    controllers = paper / "controllers" / family.folder

    def first(name: str) -> pd.DataFrame:
        table = pd.read_csv(paper / family.folder / name)
        return table[(table["strategy"] == strategy) & (table["situation"] == 0)]

    world = crowd_world(family, strategy)
    winner = Controller.load(controllers / "table1" / f"strategy{strategy}.npz").chromosome
    with np.load(controllers / "table4" / f"strategy{strategy}_evolved.npz") as saved:
        evolved = saved["population"]
    source = world.spec.in_source_layout(np.vstack([winner, evolved]))
    learnt, after, online = learn_together(world, source[0], source[1:], 0, SUMO_LEARNING)
    row = first("crowd_situations.csv").iloc[0]
    rates = {"learning": float(np.mean([run.collision_rate for run in learnt])),
             "population": after.collision_rate,
             "population_conflicts": after.conflict_rate}
    # the CSV keeps 6 significant digits
    assert rates == pytest.approx(row[list(rates)].to_dict(), rel=5e-6, abs=1e-12)
    learners = first("table4_learners.csv").drop(columns=["strategy", "situation"])
    assert learners.to_dict("records") == online.learner_rows()
    own = world.spec.from_source_layout(online.evolved_controllers())
    for learner, genes in enumerate(own):
        committed = Controller.load(controllers / "table4"
                                    / f"strategy{strategy}_learner{learner}.npz")
        np.testing.assert_array_equal(genes, committed.chromosome)


@pytest.mark.parametrize("trained, track", [("navigation_narrow", "test_zigzag30"),
                                            ("navigation_wide", "test_snake20"),
                                            ("navigation_mixed", "test_bends13")])
def test_a_committed_generalization_controller_drives_its_table_row(trained, track, root):
    """A committed seed-2 controller on a test track it never trained on: the committed
    steps, outcome and share of the track covered (a spin, a collision, the step cap)."""
    from enn_traffic.runs.evaluate import controller_trace
    from enn_traffic.sim.world import OUTCOMES

    paper = root / "results" / "paper"
    table = pd.read_csv(paper / "generalization.csv")
    row = table[(table["trained_on"] == trained) & (table["seed"] == 2)
                & (table["track"] == track)].iloc[0]
    controller = Controller.load(paper / "controllers" / "generalization"
                                 / f"{trained}_seed2.npz")
    world, poses, outcome = controller_trace(controller, shipped_scenario(track))
    assert (len(poses) - 1, OUTCOMES[outcome]) == (row["steps"], row["outcome"])
    assert round(world.track.coverage(poses[:, 0, :2]), 4) == row["coverage"]


def test_summary_md_is_what_its_records_and_csvs_give(root):
    """The committed summary.md is regenerated, byte for byte, from summary.json (when and by
    which commit each experiment ran) and the tables beside it: every line of it is its
    experiment's ``*_lines`` reading the committed CSVs now (summary.md once said 1442 where
    closed_loop.csv gave 1386), and no record stores a line of its own."""
    import json

    from enn_traffic.experiments import summary_lines
    from enn_traffic.experiments.reproduce import summary_text
    from enn_traffic.experiments.study import Study

    paper = root / "results" / "paper"
    records = json.loads((paper / "summary.json").read_text())
    summary = (paper / "summary.md").read_text()
    assert summary == summary_text(paper, records)
    assert not any("lines" in record for record in records.values())
    derived = [f"- {line}" for name in records
               for line in summary_lines(name, Study(paper, progress=False))]
    assert len(derived) == sum(line.startswith("- ") for line in summary.splitlines()) > 30
    assert all(line in summary.splitlines() for line in derived)


def test_a_changed_csv_changes_its_summary_line(root, tmp_path):
    """The departures' line follows departures.csv: one difference apart from 0 is named."""
    import shutil

    from enn_traffic.experiments.departures import departures_lines
    from enn_traffic.experiments.study import Study

    shutil.copy(root / "results" / "paper" / "departures.csv", tmp_path / "departures.csv")
    table = pd.read_csv(tmp_path / "departures.csv")
    before = departures_lines(Study(tmp_path, progress=False))[0]
    table.loc[2, ["difference_low", "difference_high"]] = [0.001, 0.02]
    table.to_csv(tmp_path / "departures.csv", index=False)
    after = departures_lines(Study(tmp_path, progress=False))[0]
    assert "0 of 19 differences apart from 0" in before
    assert "1 of 19 differences apart from 0; blame after a respawn, after:" in after
