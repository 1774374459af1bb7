"""A SUMO family's experiments end to end on a tiny budget (real libsumo, ring and grid
networks): Fig. 11, Tables 1–4 and replay against closed loop write their files, and Tables
3–4 are the means of the situations they list."""

from dataclasses import replace

import pandas as pd
import pytest

from enn_traffic.experiments.families import SUMO
from enn_traffic.experiments.study import Study
from enn_traffic.experiments.sumo_family import family_experiments

TINY = replace(SUMO, folder="tiny", seeds=(1,), incremental_max_generations=2,
               quick={**SUMO.quick, "ga": {"population_size": 10, "generations": 2,
                                           "elite_count": 2},
                      "test_situations": 1, "recheck_situations": 1, "table_situations": 1,
                      "scenario_overrides": {"episode": {"max_steps": 100},
                                             "traffic": {"warmup_s": 5.0, "episodes": 1}}})


@pytest.fixture(scope="module")
def tiny(tmp_path_factory):
    out = tmp_path_factory.mktemp("reproduce")
    lines = family_experiments(Study(out, quick=True, progress=False), TINY)
    return out / "tiny", lines


def test_every_table_and_figure_is_written(tiny):
    folder, lines = tiny
    for name in ("fig11.csv", "fig11.png", "table1.csv", "fig12.png", "table2.csv",
                 "closed_loop.csv", "table3.csv", "table4.csv", "crowd_situations.csv",
                 "table4_learners.csv", "table4_learning.csv", "table4_learning.png",
                 "table4_validation_learners.csv"):
        assert (folder / name).is_file(), name
    assert any(line.startswith("tiny/table3:") for line in lines)
    # Table 4 (§5.5.2): every learner of the first situation ends with a controller of its own
    learners = TINY.scenario(1).traffic.learners
    table4 = folder.parent / "controllers" / "tiny" / "table4"
    saved = sorted(table4.glob("*_learner*.npz"))
    assert len(saved) == 4 * learners and saved[0].name == "strategy1_learner0.npz"
    # and the evolved population each strategy's learners started from
    assert sorted(path.name for path in table4.glob("*_evolved.npz")) == [
        f"strategy{s}_evolved.npz" for s in TINY.strategies]


@pytest.mark.parametrize("trained, deployed", [(1, 4), (4, 1), (3, 3)])
def test_a_table1_entry_is_its_saved_controller_on_that_strategys_test_traffic(
        tiny, trained, deployed):
    """Row: the strategy trained on; column: the strategy deployed on. The controller saved
    for the row, driven again on the column strategy's test situations, gives the entry."""
    from enn_traffic.experiments.choosing import fitness_on_test_traffic
    from enn_traffic.runs.controller import Controller

    folder, _ = tiny
    table1 = pd.read_csv(folder / "table1.csv").set_index("training_strategy")
    assert table1.shape == (4, 4)
    # most lives reach the 100-step cap; some controllers end a life among strategy 4's
    # traffic, so the entries tell a row from a column
    assert len(set(table1.to_numpy().ravel())) > 1
    controller = Controller.load(folder.parent / "controllers" / "tiny" / "table1"
                                 / f"strategy{trained}.npz")
    study = Study(folder.parent, quick=True, progress=False)
    fitness = fitness_on_test_traffic(study, study.settings(TINY), controller.chromosome,
                                      deployed)
    assert round(fitness, 1) == table1.loc[trained, f"deploy_{deployed}"]


def test_tables_3_and_4_are_the_means_of_the_situations(tiny):
    """Table 3: the first window's means with intervals over the situations; Table 4: the
    window after learning, every arm's mean and the paired differences, whose intervals hold
    them; every learner of every situation counted, every window of the learning drawn."""
    folder, _ = tiny
    situations = pd.read_csv(folder / "crowd_situations.csv")
    assert sorted(situations.strategy.unique()) == SUMO.strategies
    means = situations.groupby("strategy").mean()
    table3 = pd.read_csv(folder / "table3.csv").set_index("strategy")
    for span in ("initial", "winner"):
        assert table3[f"{span}_collisions_per_s"].to_numpy() == pytest.approx(
            means[span].to_numpy(), abs=1e-4)
        assert table3[f"{span}_conflicts_per_h"].to_numpy() == pytest.approx(
            means[f"{span}_conflicts"].to_numpy(), abs=0.051)  # rounded to 0.1
        # both rounded to 4 places: one step of 1e-4 apart at most, and a float's ulp
        assert (table3[f"{span}_low"] <= table3[f"{span}_collisions_per_s"] + 1.001e-4).all()
    table4 = pd.read_csv(folder / "table4.csv").set_index("strategy")
    for arm in ("initial_after", "winner_after", "population"):
        assert table4[f"{arm}_collisions_per_s"].to_numpy() == pytest.approx(
            means[arm].to_numpy(), abs=1e-4)
    for before in ("initial_after", "winner_after"):
        name = f"population_minus_{before}"
        assert table4[name].to_numpy() == pytest.approx(
            (means["population"] - means[before]).to_numpy(), abs=1e-4)
        assert (table4[f"{name}_low"] <= table4[name] + 1.001e-4).all()
        assert (table4[name] <= table4[f"{name}_high"] + 1.001e-4).all()
    learners = pd.read_csv(folder / "table4_learners.csv")
    count = TINY.scenario(1).traffic.learners
    assert len(learners) == len(situations) * count
    assert (learners["chromosomes_tried"] >= learners["lives"]).all()
    curve = pd.read_csv(folder / "table4_learning.csv")
    from enn_traffic.experiments.crowds.sumo import SUMO_LEARNING
    quick = Study(folder, quick=True).settings(SUMO_LEARNING)
    assert curve.groupby("strategy").size().tolist() == [quick.windows] * 4
