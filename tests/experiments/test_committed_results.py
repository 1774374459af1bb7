"""The committed results are today's code's (issue 26, "results tied to code"): an experiment
rerun from scratch at its full settings writes the committed table byte for byte, and the
committed controllers drive as the committed tables say."""

import pandas as pd
import pytest

from enn_traffic.controller import Controller
from enn_traffic.experiments import EXPERIMENTS
from enn_traffic.experiments.lanekeeping import TEST_KEY, road_world


def test_todays_code_writes_the_committed_fig7_table(tmp_path, root):
    EXPERIMENTS["fig7"](tmp_path, quick=False, progress=False)
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
