"""The committed results are today's code's (issue 26, "results tied to code"): an experiment
rerun from scratch at its full settings writes the committed table byte for byte, and the
committed controllers drive as the committed tables say."""

import numpy as np
import pandas as pd
import pytest

from enn_traffic.controller import Controller
from enn_traffic.experiments import EXPERIMENTS
from enn_traffic.experiments.lanekeeping import TEST_KEY, road_world
from enn_traffic.experiments.protocol import ARENA, CITY, SUMO
from enn_traffic.experiments.study import Study
from enn_traffic.shipped import shipped_scenario


def test_todays_code_writes_the_committed_fig7_table(tmp_path, root):
    EXPERIMENTS["fig7"](Study(tmp_path, progress=False))
    committed = root / "results" / "paper" / "fig7.csv"
    assert (tmp_path / "fig7.csv").read_text() == committed.read_text()


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


def test_committed_table1_controllers_keep_the_pattern_on_unseen_traffic(root):
    """Each committed Table 1 specialist lives longest among the traffic it trained on, on
    200 situations of traffic seed 5000, which no training and no choice of controller drew
    (the scenarios' own seed is 1000): the paper's diagonal above the rest of every row."""
    from enn_traffic.deploy import evaluate_batch, fitness_matrix

    folder = root / "results" / "paper" / "controllers" / "table1"
    controllers = {f"strategy{s}": Controller.load(folder / f"strategy{s}.npz")
                   for s in ARENA.strategies}
    scenarios = [shipped_scenario(f"arena_strategy{s}").with_overrides(traffic={"seed": 5000})
                 for s in ARENA.strategies]
    matrix = fitness_matrix(evaluate_batch(controllers, scenarios, 200, "local", None,
                                           progress=False)).to_numpy()
    for row, own in enumerate(np.diag(matrix)):
        assert own > np.delete(matrix[row], row).max(), matrix


def test_the_committed_table1_controllers_drive_every_entry_of_their_table(root):
    """Each committed specialist on each strategy's 200 test situations: the whole committed
    Table 1, entry for entry."""
    from enn_traffic.experiments.choosing import fitness_on_test_traffic

    paper = root / "results" / "paper"
    table = pd.read_csv(paper / "table1.csv").set_index("training_strategy")
    study = Study(paper)
    for trained in ARENA.strategies:
        controller = Controller.load(paper / "controllers" / "table1" / f"strategy{trained}.npz")
        for deployed in ARENA.strategies:
            fitness = fitness_on_test_traffic(study, ARENA, controller.chromosome, deployed)
            assert round(fitness, 1) == table.loc[trained, f"deploy_{deployed}"], (trained,
                                                                                  deployed)


@pytest.mark.parametrize("family, strategy", [(SUMO, 2), (CITY, 3)], ids=["sumo", "city"])
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


def test_the_committed_table2_controller_drives_its_last_row(root):
    """Table 2's last controller, trained on all four strategies with the incremental
    network, on each strategy's 200 test situations: the committed last row, entry for
    entry, and its average."""
    from enn_traffic.experiments.choosing import fitness_on_test_traffic

    paper = root / "results" / "paper"
    last_row = pd.read_csv(paper / "table2.csv").iloc[-1]
    controller = Controller.load(paper / "controllers" / "table2" / "last_iteration.npz")
    study = Study(paper)
    fitness = [fitness_on_test_traffic(study, ARENA.incremental(), controller.chromosome, s)
               for s in ARENA.strategies]
    # the table holds one decimal, as pandas rounds it
    for strategy, value in zip(ARENA.strategies, fitness, strict=True):
        assert value == pytest.approx(last_row[f"strategy_{strategy}"], abs=0.05 + 1e-9)
    assert np.mean(fitness) == pytest.approx(last_row["average"], abs=0.05 + 1e-9)


@pytest.mark.parametrize("strategy", [1, 2, 3, 4])
def test_a_committed_table3_winner_drives_its_measured_situation(strategy, root):
    """Table 3's committed winner of a strategy, driving all 8 vehicles in the first measured
    situation: the committed collision rate of that situation, below its initial drivers'."""
    from enn_traffic.experiments.simultaneous import _broadcast
    from enn_traffic.sim.arena import ArenaWorld

    paper = root / "results" / "paper"
    situations = pd.read_csv(paper / "simultaneous_situations.csv")
    row = situations[(situations["strategy"] == strategy) & (situations["situation"] == 0)]
    world = ArenaWorld(shipped_scenario(f"arena_strategy{strategy}"))
    winner = Controller.load(paper / "controllers" / "table3" / f"strategy{strategy}.npz")
    genes = world.spec.in_source_layout(winner.chromosome)[0]
    rate = _broadcast(world, genes, situation=0)[0].collision_rate
    assert rate == pytest.approx(row["winner"].iloc[0], abs=5e-6)
    assert rate < row["initial"].iloc[0]


@pytest.mark.parametrize("trained, track", [("navigation_narrow", "test_zigzag30"),
                                            ("navigation_wide", "test_snake20"),
                                            ("navigation_mixed", "test_bends13")])
def test_a_committed_generalization_controller_drives_its_table_row(trained, track, root):
    """A committed seed-2 controller on a test track it never trained on: the committed
    steps, outcome and share of the track covered (a spin, a collision, the step cap)."""
    from enn_traffic.deploy import controller_trace
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
