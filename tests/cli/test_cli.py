"""The command line, run as a user runs it: a real process, real files."""

import argparse
import subprocess
import sys

import numpy as np
import pandas as pd
import pytest
from conftest import assert_same_run


def cli(*args, cwd=None):
    return subprocess.run([sys.executable, "-m", "enn_traffic", *map(str, args)],
                          capture_output=True, text=True, cwd=cwd)


@pytest.fixture(scope="module")
def small_run(tmp_path_factory, request):
    root = request.config.rootpath
    out = tmp_path_factory.mktemp("run") / "narrow"
    result = cli("run", root / "scenarios" / "navigation_narrow.toml", "--out", out,
                 "--population", 30, "--generations", 6, "--seed", 3, "--quiet")
    assert result.returncode == 0, result.stderr
    return out


def test_run_writes_every_output(small_run):
    for name in ("scenario.toml", "generations.csv", "best.npz", "learning_curve.png",
                 "checkpoint.npz"):
        assert (small_run / name).is_file(), name
    table = pd.read_csv(small_run / "generations.csv")
    assert list(table["generation"]) == list(range(6))
    for column in ("best_fitness", "mean_fitness", "median_fitness", "min_fitness",
                   "vehicle_steps", "elapsed_s"):
        assert column in table
    # each generation's row is its population's: its champion, driven again in that
    # generation's situations, has the row's best fitness, and best.npz is the best of all
    from enn_traffic.config import load_scenario
    from enn_traffic.runs.controller import Controller
    from enn_traffic.runs.run import RunOutputs
    from enn_traffic.sim.world import make_world

    world = make_world(load_scenario(small_run / "scenario.toml"))
    champions = RunOutputs.load(small_run).champions
    again = [world.evaluate(champion[None, :], generation).fitness[0]
             for generation, champion in enumerate(champions)]
    np.testing.assert_allclose(again, table["best_fitness"], rtol=1e-6)
    assert Controller.load(small_run / "best.npz").fitness == pytest.approx(
        table["best_fitness"].max(), rel=1e-6)
    assert (table["mean_fitness"] < table["best_fitness"]).any()


def test_resume_gives_the_uninterrupted_result(small_run, tmp_path, root):
    scenario = root / "scenarios" / "navigation_narrow.toml"
    part = tmp_path / "part"
    common = ("--population", 30, "--seed", 3, "--quiet")
    assert cli("run", scenario, "--out", part, "--generations", 2, *common).returncode == 0
    refused = cli("run", scenario, "--out", part, "--generations", 6, *common)
    assert refused.returncode == 2 and "--resume" in refused.stderr
    resumed = cli("run", scenario, "--out", part, "--generations", 6, "--resume", *common)
    assert resumed.returncode == 0, resumed.stderr
    assert_same_run(small_run, part)


def test_resume_refuses_other_settings(small_run, root):
    other = cli("run", root / "scenarios" / "navigation_narrow.toml", "--out", small_run,
                "--population", 30, "--generations", 8, "--seed", 4, "--resume", "--quiet")
    assert other.returncode == 2 and "different settings" in other.stderr


def test_evaluate_and_render_a_saved_controller(small_run, tmp_path, root):
    csv = tmp_path / "lifetimes.csv"
    result = cli("evaluate", small_run / "best.npz", root / "scenarios" / "unseen_loop.toml",
                 "--episodes", 2, "--out", csv)
    assert result.returncode == 0, result.stderr
    table = pd.read_csv(csv)
    assert len(table) == 2 and set(table["outcome"]) <= {"collision", "spin", "capped"}
    assert (table["steps"] * 0.1 == table["lifetime_s"]).all()
    assert (table["traffic_at_start"] == 0).all()  # the loop has no traffic
    picture = tmp_path / "path.png"
    result = cli("render", small_run / "best.npz", root / "scenarios" / "navigation_narrow.toml",
                 "--out", picture)
    assert result.returncode == 0, result.stderr
    assert picture.read_bytes()[:4] == b"\x89PNG"
    animation = tmp_path / "path.gif"
    result = cli("render", small_run / "best.npz", root / "scenarios" / "navigation_narrow.toml",
                 "--out", animation, "--max-steps", 20)
    assert result.returncode == 0, result.stderr
    assert animation.read_bytes()[:3] == b"GIF"


def test_evaluate_takes_a_shipped_scenarios_name_as_the_other_commands_do(small_run, tmp_path,
                                                                          root):
    """``unseen_loop``, from a folder that holds no such file, is the shipped scenario: the
    same table as its path gives. A name that is neither is refused, naming it."""
    by_path, by_name = tmp_path / "path.csv", tmp_path / "name.csv"
    result = cli("evaluate", small_run / "best.npz", root / "scenarios" / "unseen_loop.toml",
                 "--episodes", 2, "--out", by_path)
    assert result.returncode == 0, result.stderr
    result = cli("evaluate", small_run / "best.npz", "unseen_loop", "--episodes", 2,
                 "--out", by_name, cwd=tmp_path)
    assert result.returncode == 0, result.stderr
    pd.testing.assert_frame_equal(pd.read_csv(by_path), pd.read_csv(by_name))
    result = cli("evaluate", small_run / "best.npz", "no_such_scenario", cwd=tmp_path)
    assert result.returncode == 2 and "no_such_scenario" in result.stderr


def test_evaluate_reproduces_the_recorded_best_fitness(small_run, root, tmp_path):
    # no traffic on the narrow track: every situation is the training's, so the controller's
    # lifetime is the best fitness its run recorded
    best = pd.read_csv(small_run / "generations.csv")["best_fitness"].max()
    lifetimes = tmp_path / "lifetimes.csv"
    result = cli("evaluate", small_run / "best.npz", root / "scenarios" / "navigation_narrow.toml",
                 "--episodes", 2, "--out", lifetimes)
    assert result.returncode == 0, result.stderr
    assert list(pd.read_csv(lifetimes)["fitness"]) == [best, best]


def test_evaluate_on_another_traffic_seed(small_run, root, tmp_path):
    """``--traffic-seed`` draws the situations from another traffic seed: the CLI's lifetimes
    are those of the scenario with that seed, which are not the default seed's."""
    from enn_traffic.config import load_scenario
    from enn_traffic.runs.controller import Controller
    from enn_traffic.runs.evaluate import evaluate_controller

    scenario_file = root / "scenarios" / "arena_strategy1.toml"
    lifetimes = tmp_path / "lifetimes.csv"
    result = cli("evaluate", small_run / "best.npz", scenario_file, "--episodes", 3,
                 "--traffic-seed", 7, "--out", lifetimes, "--quiet")
    assert result.returncode == 0, result.stderr
    controller, scenario = Controller.load(small_run / "best.npz"), load_scenario(scenario_file)
    seeded = evaluate_controller(controller, scenario.with_overrides(traffic={"seed": 7}), 3)
    default = evaluate_controller(controller, scenario, 3)
    assert list(pd.read_csv(lifetimes)["steps"]) == list(seeded["steps"])
    assert list(seeded["steps"]) != list(default["steps"])


@pytest.mark.parametrize(
    "args, needle",
    [
        (("run", "no/such.toml"), "scenario file not found"),
        (("evaluate", "no.npz", "scenarios/navigation_narrow.toml"), "controller file not found"),
        (("reproduce", "--only", "fig99"), "unknown experiment"),
        (("run", "scenarios/navigation_narrow.toml", "--population", "-3"), "integer from 2 to"),
        (("run", "scenarios/navigation_narrow.toml", "--executor", "ray", "--address",
          "127.0.0.1:9"), "cannot reach Ray"),
        (("reproduce", "--only", "fig7", "--executor", "ray", "--address", "127.0.0.1:9",
          "--out", "/nonexistent/never-written"), "cannot reach Ray"),
    ],
)
def test_bad_input_is_one_clear_message_and_exit_2(args, needle, root):
    result = cli(*args, cwd=root)
    assert result.returncode == 2
    assert needle in result.stderr
    assert "Traceback" not in result.stderr


def test_controller_that_does_not_fit_the_sensor(small_run, tmp_path, root):
    scenario = tmp_path / "five.toml"
    text = (root / "scenarios" / "navigation_narrow.toml").read_text()
    net = (root / "sumo_nets" / "track_narrow.net.xml").as_posix()
    scenario.write_text(text.replace("beams = 19", "beams = 5")
                        .replace("../sumo_nets/track_narrow.net.xml", net))
    result = cli("evaluate", small_run / "best.npz", scenario)
    assert result.returncode == 2 and "sensor.beams" in result.stderr
    assert "Traceback" not in result.stderr
    assert str(small_run / "best.npz") in result.stderr  # which controller, in a matrix too


def test_nan_controller_is_refused(small_run, tmp_path, root):
    with np.load(small_run / "best.npz") as data:
        fields = {k: data[k] for k in data.files}
    fields["chromosome"][3] = np.nan
    broken = tmp_path / "nan.npz"
    np.savez(broken, **fields)
    result = cli("evaluate", broken, root / "scenarios" / "navigation_narrow.toml")
    assert result.returncode == 2 and "NaN" in result.stderr


def test_reproduce_quick_fig7_and_a_second_call_does_no_work(quick_fig7):
    table = pd.read_csv(quick_fig7 / "fig7.csv")
    assert list(table["seed"]) == [1, 2]
    assert (quick_fig7 / "fig7.png").is_file() and (quick_fig7 / "summary.md").is_file()
    runs = sorted((quick_fig7 / "runs").rglob("*"))
    before = {path: (path.stat().st_mtime_ns, path.read_bytes()) for path in runs
              if path.is_file()}
    again = cli("reproduce", "--quick", "--only", "fig7", "--out", quick_fig7, "--quiet")
    assert again.returncode == 0, again.stderr
    after = {path: (path.stat().st_mtime_ns, path.read_bytes())
             for path in sorted((quick_fig7 / "runs").rglob("*")) if path.is_file()}
    assert after == before  # no run file was written again, let alone recomputed
    pd.testing.assert_frame_equal(table, pd.read_csv(quick_fig7 / "fig7.csv"))


def test_scenario_with_a_broken_network(tmp_path, root):
    net = tmp_path / "broken.net.xml"
    net.write_text("<net><edge id='a'><lane id='a_0' shape='0,0 10,0' width='3'/></edge>")
    scenario = tmp_path / "s.toml"
    scenario.write_text('name = "s"\n[track]\nnet = "broken.net.xml"\nstart_xy = [1.0, 0.0]\n')
    result = cli("run", scenario, "--out", tmp_path / "out", "--generations", 1)
    assert result.returncode == 2
    assert "broken.net.xml" in result.stderr and "not a readable SUMO network" in result.stderr
    assert "Traceback" not in result.stderr


def test_summary_sets_the_papers_tables_beside_ours(tmp_path):
    from enn_traffic.report.paper_tables import paper_tables

    (tmp_path / "table1.csv").write_text(
        "training_strategy,deploy_1,deploy_2,deploy_3,deploy_4\n"
        "1,100,2,3,4\n2,5,600,7,8\n3,9,10,700,12\n4,13,14,15,800\n")
    text = "\n".join(paper_tables(tmp_path))
    assert "| 1 | 2115 / 100 | 544 / 2 | 558 / 3 | 432 / 4 |" in text
    assert "| 4 | 559 / 13 | 334 / 14 | 1080 / 15 | 2560 / 800 |" in text
    assert paper_tables(tmp_path / "empty") == []


def test_the_summary_names_the_code_and_date_of_each_experiment(quick_fig7):
    import json

    from enn_traffic.core.provenance import code_version

    record = json.loads((quick_fig7 / "summary.json").read_text())["fig7"]
    assert record["code"] == code_version() and record["date"].endswith("UTC")
    summary = (quick_fig7 / "summary.md").read_text()
    row = next(line for line in summary.splitlines() if line.startswith("| fig7 |"))
    assert f"| {code_version()} |" in row and f"| {record['seconds']} |" in row
    assert f"| all | | | | | {record['seconds']:.1f} |" in summary


def test_the_command_lines_bounds_are_the_schemas():
    """cli/args.py writes the schema's bounds again (so that --help imports no schema)."""
    from enn_traffic.cli import args
    from enn_traffic.config import EpisodeConfig, GAConfig, TrafficConfig

    def bounds(model, name):
        metadata = model.model_fields[name].metadata
        return (next(m.ge for m in metadata if hasattr(m, "ge")),
                next(m.le for m in metadata if hasattr(m, "le")))

    for parse, (lower, upper) in [(args.count, bounds(GAConfig, "generations")),
                                  (args.population, bounds(GAConfig, "population_size")),
                                  (args.steps, bounds(EpisodeConfig, "max_steps")),
                                  (args.episodes, bounds(TrafficConfig, "episodes"))]:
        assert parse(str(lower)) == lower and parse(str(upper)) == upper
        for outside in (lower - 1, upper + 1):
            with pytest.raises(argparse.ArgumentTypeError):
                parse(str(outside))


def test_bench_only_refuses_a_workload_it_does_not_have():
    result = cli("bench", "--only", "contention,warp")
    assert result.returncode == 2
    assert "--only" in result.stderr and "warp" in result.stderr
    assert "contention" in result.stderr  # the workloads it has are listed
    assert "Traceback" not in result.stderr


def test_bench_help_lists_every_workload_and_quick_leaves_out_the_long_ones():
    from enn_traffic.bench import CHECKOUT, LONG, chosen_workloads, workloads

    result = cli("bench", "--help")
    listed = " ".join(result.stdout.split())
    assert all(name in listed for name in workloads()), listed
    assert chosen_workloads() == [name for name in workloads() if name not in CHECKOUT]
    assert "test_suite" in CHECKOUT and "test_suite" in workloads()
    assert chosen_workloads(quick=True) == [name for name in workloads() if name not in LONG]
    assert chosen_workloads(quick=True, only=["reproduce_quick", "fresh", "test_suite"]) == [
        "fresh", "reproduce_quick", "test_suite"]


@pytest.mark.parametrize("preset, expected", [
    ({}, "PASSIVE"), ({"OMP_WAIT_POLICY": "ACTIVE"}, "ACTIVE"),
    ({"GOMP_SPINCOUNT": "300000"}, "unset")])
def test_idle_kernel_threads_sleep_unless_the_user_says_otherwise(preset, expected):
    """OpenMP's wait policy is set on import, before a kernel loads libgomp (docs/bench.md,
    "Sharing the cores"); a user's own setting of it, or of libgomp's spin count, stands."""
    import os

    env = {k: v for k, v in os.environ.items()
           if k not in ("OMP_WAIT_POLICY", "GOMP_SPINCOUNT")} | preset
    result = subprocess.run([sys.executable, "-c", "import os, enn_traffic; "
                             "print(os.environ.get('OMP_WAIT_POLICY', 'unset'))"],
                            capture_output=True, text=True, env=env)
    assert result.stdout.strip() == expected


def test_run_says_it_ignores_the_crowd_section(tmp_path, root):
    """``[crowd]`` is read by reproduce's crowds only: ``run`` says so, and runs."""
    text = (root / "scenarios" / "navigation_narrow.toml").read_text().replace(
        '"../sumo_nets/', f'"{root}/sumo_nets/')
    scenario = tmp_path / "narrow_counted.toml"
    scenario.write_text(text + '\n[crowd]\ncounting = "lives_lost"\n')
    result = cli("run", scenario, "--generations", 1, "--population", 10, "--out",
                 tmp_path / "out", "--quiet")
    assert result.returncode == 0, result.stderr
    assert "[crowd] is read only by 'enn-traffic crowd' and 'reproduce'" in result.stderr


def test_resume_of_a_folder_without_a_run_says_it_starts_one(tmp_path, capsys, root):
    """A mistyped --out with --resume started a fresh run without a word."""
    from enn_traffic.cli import main

    out = tmp_path / "typo"
    assert main(["run", str(root / "scenarios" / "navigation_narrow.toml"), "--out", str(out),
                 "--population", "10", "--generations", "1", "--resume", "--quiet"]) == 0
    assert f"{out} holds no run to resume: starting one" in capsys.readouterr().err
