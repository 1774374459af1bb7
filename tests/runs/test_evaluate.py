"""``enn-traffic evaluate`` with several controllers and scenarios: one tidy table of every
pair's situations, the controller x scenario matrix and its heat map; the same table on a
process pool as in one process."""

import numpy as np
import pandas as pd
import pytest
from conftest import ROOT

from enn_traffic.cli import main
from enn_traffic.config import load_scenario
from enn_traffic.core.neural import NetworkSpec
from enn_traffic.runs.controller import Controller
from enn_traffic.runs.evaluate import evaluate_batch, fitness_matrix


@pytest.fixture(scope="module")
def controllers(tmp_path_factory):
    """Two controllers of the narrow track's network: a straight driver (all genes 0) and a
    random network, saved in two folders under the same file name."""
    scenario = load_scenario(ROOT / "scenarios" / "navigation_narrow.toml")
    folder = tmp_path_factory.mktemp("controllers")
    length = 20 * 3 + 4 * 2
    paths = []
    for name, genes in (("straight", np.zeros(length)),
                        ("random", np.random.default_rng(2).uniform(-1, 1, length))):
        (folder / name).mkdir()
        Controller.from_scenario(scenario, genes, 0.0, 0).save(folder / name / "best.npz")
        paths.append(folder / name / "best.npz")
    return paths


def test_every_pair_in_one_table_with_its_matrix(controllers, root, tmp_path, capsys):
    scenarios = [root / "scenarios" / f"{n}.toml" for n in ("arena_strategy2", "unseen_loop")]
    out = tmp_path / "batch.csv"
    assert main(["evaluate", *map(str, controllers), *map(str, scenarios), "--episodes", "3",
                 "--out", str(out), "--quiet"]) == 0
    table = pd.read_csv(out)
    assert list(table.columns[:5]) == ["controller", "scenario", "track", "strategy",
                                       "situation"]
    assert {"steps", "outcome", "suffered", "distance_m", "traffic_at_start",
            "traffic_near_mean", "traffic_near_max"} <= set(table.columns)
    assert len(table) == 2 * 2 * 3
    assert set(table["controller"]) == {"straight/best", "random/best"}  # told apart
    arena = table[table["scenario"] == "arena_strategy2"]
    assert (arena["traffic_at_start"] == 7).all()  # the arena's 7 other vehicles
    assert (table[table["scenario"] == "unseen_loop"]["traffic_near_max"] == 0).all()
    matrix = pd.read_csv(tmp_path / "batch_matrix.csv", index_col="controller")
    assert matrix.shape == (2, 2)
    for (controller, scenario), group in table.groupby(["controller", "scenario"]):
        assert matrix.loc[controller, scenario] == pytest.approx(group["fitness"].mean(), abs=1e-3)
    assert (tmp_path / "batch_matrix.png").read_bytes()[:4] == b"\x89PNG"
    printed = capsys.readouterr().out
    assert "straight/best" in printed and "unseen_loop" in printed


def test_a_process_pool_gives_the_local_table(controllers, root):
    labelled = {f"c{i}": Controller.load(p) for i, p in enumerate(controllers)}
    scenarios = [load_scenario(root / "scenarios" / f"{n}.toml")
                 for n in ("arena_strategy4", "navigation_narrow")]
    local = evaluate_batch(labelled, scenarios, episodes=2, progress=False)
    pooled = evaluate_batch(labelled, scenarios, episodes=2, executor="process",
                            progress=False)
    pd.testing.assert_frame_equal(local, pooled)
    assert fitness_matrix(local).index.tolist() == ["c0", "c1"]


def test_a_misfit_controller_is_refused_before_anything_runs(controllers, root, tmp_path,
                                                             capsys):
    """The lane-keeping camera gives 8 inputs, the controllers take 19 beams."""
    code = main(["evaluate", str(controllers[0]), str(root / "scenarios" / "unseen_loop.toml"),
                 str(root / "scenarios" / "lane_keeping.toml"), "--quiet"])
    assert code == 2
    assert "lane_keeping.toml" in capsys.readouterr().err


def test_evaluate_needs_a_controller_and_a_scenario(root, capsys):
    assert main(["evaluate", str(root / "scenarios" / "unseen_loop.toml")]) == 2
    assert "at least one controller" in capsys.readouterr().err


def test_a_controller_is_measured_by_the_spin_rule_it_was_evolved_under(root, tmp_path):
    """The arena's spin rule (300 steps, 300 m²) travels with an arena controller onto a
    navigation track, whose own rule is the paper's (49, 64); a file written before the rule
    was kept leaves the scenario's rule."""
    arena = load_scenario(root / "scenarios" / "arena_strategy1.toml")
    track = load_scenario(root / "scenarios" / "unseen_zigzag14.toml")
    genes = np.zeros(NetworkSpec(arena.layer_sizes).chromosome_length)
    saved = tmp_path / "arena.npz"
    Controller.from_scenario(arena, genes, 1.0, 0).save(saved)
    fitted = Controller.load(saved).fit(track).episode
    assert (fitted.spin_window, fitted.spin_variance) == (300, 300.0)
    assert fitted.max_steps == track.episode.max_steps
    with np.load(saved) as data:
        older = {k: data[k] for k in data.files if not k.startswith("spin_")}
    np.savez(tmp_path / "older.npz", **older)
    kept = Controller.load(tmp_path / "older.npz").fit(track).episode
    assert (kept.spin_window, kept.spin_variance) == (49, 64.0)


def test_a_gif_shows_a_small_track_whole_and_follows_the_learner_on_a_large_map():
    """The view (report.plots.square_view) of a path inside a 100 m arena covers the arena;
    of a path on a 2 km map, it holds the path and its margin, a small part of the map."""
    from enn_traffic.report.animate import FOLLOW_M
    from enn_traffic.report.plots import square_view

    def box(size):  # the four walls of a square of side ``size``
        return np.array([[0, 0, size, 0], [size, 0, size, size], [size, size, 0, size],
                         [0, size, 0, 0]], dtype=float)

    path = np.array([[40.0, 40.0], [60.0, 45.0], [np.nan, np.nan]])
    low, high = square_view(path, FOLLOW_M / 2, box(100.0))
    assert (low <= 0).all() and (high >= 100).all() and high[0] - low[0] <= FOLLOW_M
    low, high = square_view(path + 900.0, FOLLOW_M / 2, box(2000.0))
    assert high[0] - low[0] > FOLLOW_M  # wider than the view: the GIF follows the learner
    assert (low <= 940 - FOLLOW_M / 2).all() and (high >= 945 + FOLLOW_M / 2).all()
    assert high[0] - low[0] < 200


def test_lane_keeping_is_evaluated_on_as_many_situations_as_asked(tmp_path, capsys):
    """``evaluate lk.npz lane_keeping --episodes 3``: three lives, where it was refused for
    [traffic] keys the scenario does not have (lane keeping keeps its episodes in
    ``[lane_keeping]``)."""
    from enn_traffic.config.shipped import shipped_scenario

    scenario = shipped_scenario("lane_keeping")
    genes = np.zeros(NetworkSpec(scenario.layer_sizes).chromosome_length)
    controller = tmp_path / "lk.npz"
    Controller.from_scenario(scenario, genes, 0.0, 0).save(controller)
    out = tmp_path / "lk.csv"
    assert main(["evaluate", str(controller), "lane_keeping", "--episodes", "3", "--out",
                 str(out), "--quiet"]) == 0
    assert pd.read_csv(out)["situation"].tolist() == [0, 1, 2]
