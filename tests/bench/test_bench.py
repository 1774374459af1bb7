"""The bench's own machinery: the networks it generates are kept in the cache folder."""

import re
import subprocess

import numpy as np
import pytest

from enn_traffic import bench
from enn_traffic.bench.measure import generated


def test_a_generated_network_is_made_once_and_a_failed_one_leaves_nothing(tmp_path,
                                                                          monkeypatch):
    monkeypatch.setenv("ENN_TRAFFIC_CACHE", str(tmp_path))
    made = []

    def make(folder):
        made.append(folder)
        (folder / "city.net.xml").write_text("<net/>")

    first = generated("city", make)
    assert generated("city", make) == first and len(made) == 1
    assert (first / "city.net.xml").read_text() == "<net/>"

    def broken(folder):
        (folder / "half.net.xml").write_text("<net")
        raise subprocess.CalledProcessError(1, "netgenerate")

    with pytest.raises(subprocess.CalledProcessError):
        generated("broken", broken)
    assert sorted(path.name for path in first.parent.iterdir()) == ["city"]


def test_the_printed_table_has_a_block_per_workload_with_its_own_columns():
    import numpy as np
    import pandas as pd

    table = pd.DataFrame([
        {"workload": "navigation: narrow", "implementation": "compiled", "threads": 2,
         "seconds": 0.0512, "vehicle_steps_per_s": 1_234_567.8, "calls": np.nan},
        {"workload": "navigation: narrow", "implementation": "plain", "threads": 1,
         "seconds": 1.0, "vehicle_steps_per_s": 1_500.0, "calls": np.nan},
        {"workload": "fresh process: one arm", "implementation": "forked", "threads": 2,
         "seconds": 0.4, "vehicle_steps_per_s": np.nan, "calls": 3.0}])
    navigation, fresh = bench.table_text(table).split("\n\n")
    assert "1,234,568" in navigation and "0.05" in navigation and "calls" not in navigation
    assert "vehicle_steps_per_s" not in fresh and fresh.splitlines()[1].split()[-1] == "3"
    assert "nan" not in (navigation + fresh).lower()


@pytest.mark.full
def test_the_marginal_row_adds_as_many_sumo_vehicles_and_learners_as_it_says():
    """crowd_marginal's arms on the small city: the SUMO-driven vehicles it adds drive (SUMO
    routes them, an arrived one is replaced) and the learners it adds are SUMO vehicles too,
    so that each arm's cost is that of the vehicles its row names."""
    from enn_traffic.bench.marginal import marginal_seconds
    from enn_traffic.bench.measure import city_with_lights
    from enn_traffic.sumo.fresh import fresh_calls

    net, trips = city_with_lights(150, 0.5)
    alone, vehicles, learners = fresh_calls([(marginal_seconds, net, trips, 0, 1, 20),
                                             (marginal_seconds, net, trips, 30, 1, 20),
                                             (marginal_seconds, net, trips, 0, 31, 20)])
    assert vehicles["added_driving"] >= 27  # a few may wait for room on their first edge
    assert vehicles["vehicles"] >= alone["vehicles"] + 27
    assert learners["vehicles"] < alone["vehicles"] + 15  # learners are not SUMO's own
    assert learners["entries"] > alone["entries"]
    for part in ("move", "read", "kernels", "reenter"):
        assert learners[f"{part}_seconds"] > 0


@pytest.mark.full
def test_two_checkouts_measured_interleaved_give_a_learners_cost_by_part(root, render):
    """bench.checkouts on the small city, this checkout as both, two rounds: eight runs (each
    checkout with many learners and with one, in order), each with its commit, and
    docs/bench.md's reading of them: a cost per learner-step of each checkout, by part, the
    median of the rounds within their range."""
    from enn_traffic.bench.checkouts import compare

    table = compare({"before": root, "after": root}, learners=6, steps=20, rounds=2,
                    caches=None, city=150)
    assert table[["checkout", "learners"]].values.tolist() == [
        ["before", 6], ["before", 1], ["after", 6], ["after", 1]] * 2
    assert table["commit"].str.fullmatch(r"[0-9a-f]{12}(\+changes)?").all()
    from contexts.bench import checkouts  # importable while the ``render`` fixture lasts

    figures = checkouts(table)  # differences of small timings: any sign, always finite
    for label in ("before", "after"):
        row = figures[label]
        assert (row["commit"], row["rounds"], row["learners"], row["steps"]) == (
            table["commit"].iloc[0], 2, 6, 20)
        assert all(np.isfinite(row[part]) for part in ("all", "sumo", "move", "read",
                                                       "kernels", "reenter"))
        assert row["all_min"] <= row["all"] <= row["all_max"]  # the median of the rounds


def test_checkouts_refuses_what_is_not_a_work_tree_and_rounds_below_one(tmp_path, root,
                                                                       capsys):
    """``python -m enn_traffic.bench.checkouts`` given a commit instead of a folder, or no
    round, says so in one line with exit status 2, before anything runs."""
    from enn_traffic.bench.checkouts import main

    for argv, said in ([["abc123", str(root), "--out", str(tmp_path / "x.csv")],
                        "before: .* is not a work tree of the project"],
                       [[str(root), str(root), "--out", str(tmp_path / "x.csv"), "--rounds",
                         "0"], "--rounds: must be at least 1, not 0"]):
        with pytest.raises(SystemExit) as stopped:
            main(argv)
        assert stopped.value.code == 2
        assert re.search(said, capsys.readouterr().err)
    assert not (tmp_path / "x.csv").exists()
