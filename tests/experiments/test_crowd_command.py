"""``enn-traffic crowd``: Tables 3–4 on a user's SUMO scenario, with a real SUMO (the shipped
ring road), its individual GA, its crowds and its files; resumed, refused, and on a local Ray."""

import json
import shutil

import numpy as np
import pandas as pd
import pytest

from enn_traffic.cli import main
from enn_traffic.core.errors import shown

CROWD = """
[crowd]
learning_s = 10.0
window_s = 5.0
life_cap_steps = 30
population_size = 6
elite_count = 2
situations = 2
validation_situations = 1
"""


def ring_scenario(root, folder, learners: int = 4, extra: str = CROWD, name: str = "ring"):
    """The shipped ring road of SUMO strategy 1 as a user's file: a tiny GA, a short crowd."""
    text = (root / "scenarios" / "sumo_strategy1.toml").read_text()
    text = text.replace('"../sumo_nets/', f'"{root}/sumo_nets/').replace(
        '"routes/', f'"{root}/scenarios/routes/').replace(
        "population_size = 200", "population_size = 8").replace(
        "generations = 20", "generations = 1").replace("elite_count = 20", "elite_count = 2")
    text = text.replace('name = "sumo_strategy1"', f'name = "{name}"').replace(
        "episodes = 2", f"episodes = 1\nlearners = {learners}")
    path = folder / f"{name}.toml"
    path.write_text(text + extra)
    return path


@pytest.fixture(scope="module")
def crowd_run(tmp_path_factory, request):
    root = request.config.rootpath
    folder = tmp_path_factory.mktemp("crowd")
    scenario = ring_scenario(root, folder)
    assert main(["crowd", str(scenario), "--out", str(folder / "out"), "--quiet"]) == 0
    return scenario, folder / "out"


def test_crowd_writes_tables_3_and_4_the_curve_the_controllers_and_the_gif(crowd_run):
    _, out = crowd_run
    for name in ["table3.csv", "table4.csv", "table4_learners.csv", "table4_learning.csv",
                 "table4_learning.png", "crowd_situations.csv", "crowd.gif", "crowd.toml",
                 "table4_validation_learners.csv", "individual/best.npz",
                 "individual/generations.csv"]:
        assert (out / name).is_file(), name
    assert sorted(p.name for p in (out / "controllers").iterdir()) == [
        f"learner{k}.npz" for k in range(4)]
    situations = pd.read_csv(out / "crowd_situations.csv")
    assert list(situations["situation"]) == [0, 1]
    for arm in ["initial", "winner", "initial_after", "winner_after", "population"]:
        assert situations[arm].between(0, 10).all(), arm  # collisions per learner-second
    learners = pd.read_csv(out / "table4_learners.csv")
    assert len(learners) == 2 * 4  # every learner of every situation
    table4 = pd.read_csv(out / "table4.csv")
    assert {"population_minus_initial_after_low", "population_minus_initial_after_high"} <= set(
        table4.columns)
    curve = pd.read_csv(out / "table4_learning.csv")
    assert len(curve) == 2  # the 10 s of learning in windows of 5 s
    cost = pd.read_csv(out / "crowd_cost.csv")  # what each arm of each situation cost
    assert len(cost) == 2 * 3 and set(cost["arm"]) == {"initial drivers", "the winner",
                                                       "learning together"}
    learner_s = 4 * 10 * 10  # 4 learners, 10 s of SUMO time (two windows of 5 s), 0.1 s steps
    assert (cost[cost["arm"] == "learning together"]["learner_steps"] == learner_s + 200).all()
    assert ((cost["sumo_s"] > 0) & (cost["sumo_s"] < cost["wall_s"])
            & (cost["wall_s"] < cost["situation_wall_s"])).all()
    # CPU time: SUMO's within the arm's, the arm's no more than its wall time (one thread)
    assert ((cost["sumo_cpu_s"] > 0) & (cost["sumo_cpu_s"] <= cost["cpu_s"])
            & (cost["cpu_s"] <= cost["wall_s"] + 0.05)).all()


def test_a_resumed_crowd_measures_nothing_again_and_another_folder_is_refused(crowd_run, capsys):
    scenario, out = crowd_run
    kept = {p: p.stat().st_mtime_ns for p in [*(out / "crowds").iterdir(), out / "crowd.gif"]}
    assert main(["crowd", str(scenario), "--out", str(out), "--quiet"]) == 2
    assert "holds a crowd run; --resume continues it" in capsys.readouterr().err
    assert main(["crowd", str(scenario), "--out", str(out), "--resume", "--quiet"]) == 0
    assert {p: p.stat().st_mtime_ns for p in kept} == kept
    situation = json.loads((out / "crowds" / "strategy1_situation0.json").read_text())
    assert situation["settings"]["learning_s"] == 10.0


@pytest.mark.parametrize("same_rules", [True, False])
def test_a_crowd_kept_under_an_earlier_digest_of_the_same_rules_is_not_measured_again(
        crowd_run, tmp_path, monkeypatch, capsys, same_rules):
    """The rules' digest moves (code moved between files, say: here a digest of its own).
    Where the digest the crowd was kept under is listed in provenance.SAME_RULES, it resumes
    and measures nothing, its individual run included; where not, the run is refused as
    made by other rules."""
    from enn_traffic.core.provenance import rules_version
    from enn_traffic.experiments.crowds import sumo
    from enn_traffic.runs import run

    scenario, out = crowd_run
    copy = tmp_path / "out"
    shutil.copytree(out, copy)
    kept = {p: p.stat().st_mtime_ns for p in [*(copy / "crowds").iterdir(),
                                               copy / "individual" / "checkpoint.npz"]}
    made_by = rules_version()
    for module in (sumo, run):
        monkeypatch.setattr(module, "rules_version", lambda: "fedcba987654")
        monkeypatch.setattr(module, "SAME_RULES", (made_by,) if same_rules else ())
    status = main(["crowd", str(scenario), "--out", str(copy), "--resume", "--quiet"])
    assert [p for p in kept if p.stat().st_mtime_ns != kept[p]] == []
    if same_rules:
        assert status == 0
    else:
        assert status == 2 and f"made by other rules ({made_by}" in capsys.readouterr().err


def test_a_scenario_without_sumo_traffic_is_refused(root, tmp_path, capsys):
    path = root / "scenarios" / "arena_strategy1.toml"
    assert main(["crowd", str(path), "--out", str(tmp_path / "out"), "--quiet"]) == 2
    error = capsys.readouterr().err
    assert f"{shown(str(path))}: traffic.strategy" in error and 'strategy = "sumo"' in error, \
        error  # named relative to the working folder, which holds it


def test_a_crowd_resumed_with_other_learners_measures_again_but_not_its_ga(crowd_run,
                                                                          tmp_path):
    """Kept situations are keyed by the scenario (its learners); the individual run by what
    it learnt on, which the crowd's keys leave alone."""
    scenario, out = crowd_run
    copy = tmp_path / "out"
    shutil.copytree(out, copy)
    assert main(["crowd", str(scenario), "--out", str(copy), "--resume", "--learners", "3",
                 "--quiet"]) == 0
    assert len(pd.read_csv(copy / "table4_learners.csv")) == 2 * 3
    assert sorted(p.name for p in (copy / "controllers").iterdir()) == [
        f"learner{k}.npz" for k in range(3)]
    for name in ["checkpoint.npz", "generations.csv", "best.npz"]:
        assert (copy / "individual" / name).read_bytes() == (
            out / "individual" / name).read_bytes()


@pytest.mark.parametrize("change, key", [
    ("learners = 4", "traffic.learners"),
    ("population_size = 6", "crowd.population_size"),
    ("learning_s = 10.0", "crowd.learning_s"),
])
def test_a_crowd_that_cannot_run_is_refused_naming_the_key(root, tmp_path, capsys, change,
                                                           key):
    replacement = {"traffic.learners": "learners = 900",
                   "crowd.population_size": "population_size = 9",
                   "crowd.learning_s": "learning_s = 12.0"}[key]
    path = ring_scenario(root, tmp_path)
    path.write_text(path.read_text().replace(change, replacement))
    assert main(["crowd", str(path), "--out", str(tmp_path / "out"), "--quiet"]) == 2
    error = capsys.readouterr().err
    assert f"{path}" in error and key in error, error
    assert not (tmp_path / "out").exists()


def test_too_many_learners_from_the_command_line_name_the_option(root, tmp_path, capsys):
    path = ring_scenario(root, tmp_path)
    assert main(["crowd", str(path), "--learners", "900", "--out", str(tmp_path / "out"),
                 "--quiet"]) == 2
    error = capsys.readouterr().err
    assert "--learners: 900 learners do not fit" in error and str(path) not in error, error


def test_a_folder_of_other_files_is_refused_without_force(root, tmp_path, capsys):
    (tmp_path / "out").mkdir()
    (tmp_path / "out" / "mine.csv").write_text("a,b\n")
    path = ring_scenario(root, tmp_path)
    assert main(["crowd", str(path), "--out", str(tmp_path / "out"), "--quiet"]) == 2
    assert "holds files but no crowd run" in capsys.readouterr().err
    assert (tmp_path / "out" / "mine.csv").read_text() == "a,b\n"


@pytest.mark.full
def test_crowd_situations_on_ray_are_the_local_ones(crowd_run, tmp_path):
    """Each situation a Ray task of a local Ray (2 workers): the same table."""
    import ray

    from enn_traffic.config import load_scenario
    from enn_traffic.experiments.crowds.user import run_crowd

    scenario, out = crowd_run
    ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False,
             configure_logging=False)
    try:
        run_crowd(load_scenario(scenario), tmp_path / "ray", executor="ray", progress=False)
    finally:
        ray.shutdown()
    for name in ["crowd_situations.csv", "table4_learners.csv", "table3.csv", "table4.csv"]:
        pd.testing.assert_frame_equal(pd.read_csv(tmp_path / "ray" / name),
                                      pd.read_csv(out / name))
    for k in range(4):
        with np.load(out / "controllers" / f"learner{k}.npz") as local, \
                np.load(tmp_path / "ray" / "controllers" / f"learner{k}.npz") as spread:
            np.testing.assert_array_equal(local["chromosome"], spread["chromosome"])


@pytest.mark.full
def test_a_ray_worker_killed_in_a_situation_gives_the_uninterrupted_tables(crowd_run, tmp_path):
    """SIGKILL to the Ray worker running a situation (as the OOM killer would): Ray runs the
    task again, and the crowd ends with the tables and controllers of a run never disturbed."""
    import os
    import signal
    import subprocess
    import sys
    import time

    scenario, out = crowd_run
    broken = tmp_path / "broken"
    process = subprocess.Popen([sys.executable, "-m", "enn_traffic", "crowd", str(scenario),
                                "--out", str(broken), "--executor", "ray", "--quiet"],
                               stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    killed, deadline = None, time.monotonic() + 300
    while killed is None and process.poll() is None and time.monotonic() < deadline:
        found = subprocess.run(["pgrep", "-f", "ray::_situation_task"], capture_output=True,
                               text=True).stdout.split()
        if found:
            time.sleep(0.3)  # inside its SUMO
            killed = int(found[0])
            os.kill(killed, signal.SIGKILL)
        time.sleep(0.05)
    stderr = process.communicate(timeout=600)[1]
    assert killed is not None, "no situation task to kill before the crowd ended"
    assert process.returncode == 0, stderr
    for name in ["crowd_situations.csv", "table4_learners.csv", "table3.csv", "table4.csv"]:
        pd.testing.assert_frame_equal(pd.read_csv(broken / name), pd.read_csv(out / name))
    for k in range(4):
        with np.load(out / "controllers" / f"learner{k}.npz") as whole, \
                np.load(broken / "controllers" / f"learner{k}.npz") as again:
            np.testing.assert_array_equal(whole["chromosome"], again["chromosome"])


def test_a_scenario_named_like_the_crowds_own_file_is_never_written_over(root, tmp_path, capsys):
    """A newcomer's scenario ``OUT/crowd.toml`` was taken for a crowd run, and ``--resume``
    wrote the crowd's copy of the scenario over it."""
    path = ring_scenario(root, tmp_path, name="crowd")
    text = path.read_text()
    for flags in ([], ["--resume"], ["--force"]):
        assert main(["crowd", str(path), "--out", str(tmp_path), "--quiet", *flags]) == 2
        assert "is the scenario's own folder" in capsys.readouterr().err, flags
    assert path.read_text() == text
