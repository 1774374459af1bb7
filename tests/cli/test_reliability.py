"""Faults and bad input: a killed run resumes without loss, a broken scenario never gives a
traceback."""

import math
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import tomli_w
from conftest import FIG7_RUNS, assert_same_run
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from enn_traffic.config import load_scenario
from enn_traffic.core.errors import InputError
from enn_traffic.learning.ga import GAState
from enn_traffic.runs.controller import Controller
from enn_traffic.runs.run import CHECKPOINT

RUN = ("--population", 40, "--generations", 12, "--seed", 5, "--quiet")


def _run(*args, wait=True):
    command = [sys.executable, "-m", "enn_traffic", *map(str, args)]
    if wait:
        return subprocess.run(command, capture_output=True, text=True)
    return subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)


def _generation_done(out) -> int:
    try:
        return len(pd.read_csv(out / "generations.csv"))
    except (FileNotFoundError, pd.errors.EmptyDataError):
        return 0


def _kill_after(*args, watch, generations: int) -> None:
    """Start the command line ``args`` and SIGKILL it once the run in ``watch`` has finished
    ``generations`` generations (or it ended by itself)."""
    process = _run(*args, wait=False)
    deadline = time.monotonic() + 120
    while _generation_done(watch) < generations and process.poll() is None:
        assert time.monotonic() < deadline, "the command never got going"
        time.sleep(0.01)
    process.send_signal(signal.SIGKILL)
    process.wait()


def test_run_killed_mid_run_resumes_to_the_uninterrupted_result(tmp_path, root):
    """SIGKILL while a run is between generations 2 and 12, then --resume: the same
    generations.csv (but elapsed time) and the same final population as a run never killed."""
    scenario = root / "scenarios" / "arena_strategy1.toml"
    whole = tmp_path / "whole"
    assert _run("run", scenario, "--out", whole, *RUN).returncode == 0
    killed = tmp_path / "killed"
    _kill_after("run", scenario, "--out", killed, *RUN, watch=killed, generations=2)
    assert _generation_done(killed) < 12, "the run finished before it could be killed"
    resumed = _run("run", scenario, "--out", killed, "--resume", *RUN)
    assert resumed.returncode == 0, resumed.stderr
    assert_same_run(whole, killed)
    assert not list(killed.glob("*.tmp")), "a half-written file was left behind"


def test_reproduce_killed_mid_run_resumes_to_the_uninterrupted_result(tmp_path, quick_fig7):
    """SIGKILL ``reproduce`` while its first run is under way; the next call finishes every
    run as if never interrupted and writes the same table."""
    out = tmp_path / "killed"
    first = out / FIG7_RUNS[0]
    _kill_after("reproduce", "--quick", "--only", "fig7", "--out", out, "--quiet", watch=first,
                generations=3)
    assert _generation_done(first) < 20 and not (out / "fig7.csv").exists()
    resumed = _run("reproduce", "--quick", "--only", "fig7", "--out", out, "--quiet")
    assert resumed.returncode == 0, resumed.stderr
    for run in FIG7_RUNS:
        assert_same_run(quick_fig7 / run, out / run)
    pd.testing.assert_frame_equal(pd.read_csv(quick_fig7 / "fig7.csv"),
                                  pd.read_csv(out / "fig7.csv"))


def test_truncated_checkpoint_is_reported_not_loaded(tmp_path, root):
    scenario = root / "scenarios" / "navigation_narrow.toml"
    out = tmp_path / "run"
    assert _run("run", scenario, "--out", out, "--population", 20, "--generations", 2,
                "--quiet").returncode == 0
    data = (out / "checkpoint.npz").read_bytes()
    (out / "checkpoint.npz").write_bytes(data[: len(data) // 2])
    result = _run("run", scenario, "--out", out, "--population", 20, "--generations", 4,
                  "--resume", "--quiet")
    assert result.returncode == 2
    assert "checkpoint" in result.stderr and "Traceback" not in result.stderr


def _flipped_copies(path):
    """``path`` with each of its bytes inverted in turn (one damaged file per byte)."""
    data = path.read_bytes()
    damaged = path.with_name("damaged" + path.suffix)
    for position in range(len(data)):
        copy = bytearray(data)
        copy[position] ^= 0xFF
        damaged.write_bytes(bytes(copy))
        yield damaged


def test_every_flipped_byte_in_a_checkpoint_is_reported_or_harmless(tmp_path):
    """Corruption, not only truncation: a checkpoint with any one byte inverted either loads
    exactly the saved state (the byte was zip metadata such as a time stamp) or is refused."""
    rng = np.random.default_rng(3)
    saved = GAState(generation=3, population=rng.random((4, 5)), rng=rng,
                    best_chromosome=np.ones(5), best_fitness=2.0, fingerprint="f",
                    extra={"elapsed_s": 1.5})
    path = tmp_path / "checkpoint.npz"
    saved.save(path)
    refused = 0
    for damaged in _flipped_copies(path):
        try:
            state = GAState.load(damaged)
        except InputError:
            refused += 1
            continue
        assert (state.generation, state.fingerprint, state.best_fitness, state.extra) == \
            (3, "f", 2.0, {"elapsed_s": 1.5})
        np.testing.assert_array_equal(state.population, saved.population)
        np.testing.assert_array_equal(state.best_chromosome, saved.best_chromosome)
        assert state.rng.bit_generator.state == saved.rng.bit_generator.state
    assert refused > len(path.read_bytes()) // 2


def test_every_flipped_byte_in_a_controller_is_reported_or_harmless(tmp_path):
    saved = Controller(chromosome=np.linspace(-1, 1, 8 * 3 + 4 * 2), layer_sizes=(7, 3, 2),
                       layout="source", steering_gain_deg=90.0, span_deg=180.0, range=25.0,
                       fitness=10.0, scenario_name="s", generation=2)
    path = tmp_path / "best.npz"
    saved.save(path)
    for damaged in _flipped_copies(path):
        try:
            controller = Controller.load(damaged)
        except InputError:
            continue
        np.testing.assert_array_equal(controller.chromosome, saved.chromosome)
        assert controller.layer_sizes == saved.layer_sizes and controller.range == saved.range


def test_damaged_generations_table_stops_a_resume_without_touching_the_run(tmp_path, root):
    scenario = root / "scenarios" / "navigation_narrow.toml"
    out = tmp_path / "run"
    common = ("--population", 20, "--quiet")
    assert _run("run", scenario, "--out", out, "--generations", 3, *common).returncode == 0
    checkpoint = (out / "checkpoint.npz").read_bytes()
    table = out / "generations.csv"
    rows = table.read_text().splitlines()
    for damage in ("\x00\x01 not a table", "\n".join(rows[:2]) + "\n"):
        table.write_text(damage)
        result = _run("run", scenario, "--out", out, "--generations", 5, "--resume", *common)
        assert result.returncode == 2, result.stderr
        assert "generations.csv" in result.stderr and "--force" in result.stderr
        assert "Traceback" not in result.stderr
        assert (out / "checkpoint.npz").read_bytes() == checkpoint


def test_folder_of_another_scenario_is_never_overwritten_without_force(tmp_path, root):
    out = tmp_path / "run"
    narrow, arena = (root / "scenarios" / f"{name}.toml"
                     for name in ("navigation_narrow", "arena_strategy1"))
    common = ("--population", 30, "--generations", 2, "--quiet")
    assert _run("run", narrow, "--out", out, *common).returncode == 0
    before = {path.name: path.read_bytes() for path in out.iterdir()}
    for flags in ((), ("--resume",)):
        refused = _run("run", arena, "--out", out, *flags, *common)
        assert refused.returncode == 2 and "--force" in refused.stderr, flags
        assert "Traceback" not in refused.stderr
        assert {path.name: path.read_bytes() for path in out.iterdir()} == before, flags
    assert _run("run", arena, "--out", out, "--force", *common).returncode == 0
    assert 'name = "arena_strategy1"' in (out / "scenario.toml").read_text()


def test_a_run_never_writes_over_the_users_files_or_its_own_scenario(tmp_path, root, capsys):
    """A folder of the user's own files (no run of this tool) is refused without --force; the
    folder that holds the scenario file is refused even with --force: the run would write its
    copy of the scenario over it."""
    from enn_traffic.cli import main

    text = (root / "scenarios" / "navigation_narrow.toml").read_text().replace(
        '"../sumo_nets/', f'"{root}/sumo_nets/')
    mine = tmp_path / "mine"
    mine.mkdir()
    (mine / "scenario.toml").write_text(text)
    (mine / "generations.csv").write_text("my,own\n1,2\n")
    (mine / "best.npz").write_bytes(b"my own controller")
    before = {path.name: path.read_bytes() for path in mine.iterdir()}
    other = tmp_path / "other.toml"
    other.write_text(text)
    common = ["--population", "10", "--generations", "1", "--quiet"]
    assert main(["run", str(other), "--out", str(mine), *common]) == 2
    assert "holds files but no run to resume (best.npz, generations.csv, scenario.toml)" in (
        capsys.readouterr().err)
    for flags in ([], ["--force"]):
        assert main(["run", str(mine / "scenario.toml"), "--out", str(mine), *flags,
                     *common]) == 2
        assert "is the scenario's own folder" in capsys.readouterr().err, flags
    assert {path.name: path.read_bytes() for path in mine.iterdir()} == before


def test_a_missing_path_is_never_read_as_the_shipped_scenario_of_its_name(tmp_path, capsys,
                                                                        monkeypatch):
    """Only a bare name (no folder, no suffix) names a shipped scenario: a mistyped path is
    refused, not silently replaced."""
    from enn_traffic.cli import main
    from enn_traffic.config.shipped import SCENARIOS, scenario_path

    monkeypatch.chdir(tmp_path)  # no scenarios/ folder here
    for typed in ("scenarios/navigation_narrow.toml", "navigation_narrow.toml",
                  "mine/navigation_narrow"):
        assert main(["run", typed, "--out", str(tmp_path / "out"), "--quiet"]) == 2, typed
        assert f"{typed}: file not found (the shipped scenario of that name is given as " \
               "'navigation_narrow' alone)" in capsys.readouterr().err
    assert scenario_path("navigation_narrow") == SCENARIOS / "navigation_narrow.toml"
    assert not (tmp_path / "out").exists()


def test_an_edited_checkpoint_is_refused_naming_its_field_and_best_npz_is_kept(tmp_path, root,
                                                                             capsys):
    """Issue 64: a checkpoint whose settings match but whose arrays were edited resumed with
    them (3 rows of a population of 10) or rewrote ``best.npz`` from them (NaN, 5 genes)."""
    from enn_traffic.cli import main

    scenario = str(root / "scenarios" / "navigation_narrow.toml")
    common = ["--population", "10", "--seed", "2", "--quiet"]
    source = tmp_path / "run"
    assert main(["run", scenario, "--out", str(source), "--generations", "2", *common]) == 0
    with np.load(source / CHECKPOINT) as saved:
        data = dict(saved)
    edits = {"population": data["population"][:3], "best_chromosome": data["best_chromosome"][:5],
             "champions": data["champions"][:, :4], "generation": np.array(-1)}
    edits = [(field, {field: value}) for field, value in edits.items()] + [
        ("best_chromosome", {"best_chromosome": data["best_chromosome"] * np.nan}),
        ("population", {"population": data["population"].astype(complex)}),
        ("extra", {"extra": np.array("[1, 2]")})]
    for field, edit in edits:
        out = tmp_path / f"edited_{len(list(tmp_path.iterdir()))}"
        out.mkdir()
        for name in ("best.npz", "generations.csv", "scenario.toml", "outputs.npz"):
            (out / name).write_bytes((source / name).read_bytes())
        np.savez(out / CHECKPOINT, **(data | edit))
        assert main(["run", scenario, "--out", str(out), "--generations", "3", "--resume",
                     *common]) == 2, field
        assert f"{out / CHECKPOINT}: {field}: " in capsys.readouterr().err, field
        assert (out / "best.npz").read_bytes() == (source / "best.npz").read_bytes(), field


@pytest.mark.parametrize("field, edit, message", [
    ("chromosome", lambda c: c + 1j, "holds complex128 values, not real numbers"),
    ("chromosome", lambda c: np.array(["a"] * len(c)), "holds <U1 values, not real numbers"),
    ("layer_sizes", lambda sizes: sizes + 0.5, "are not whole numbers"),
])
def test_a_controller_of_complex_or_fractional_numbers_is_refused(tmp_path, root, field, edit,
                                                                  message):
    """Issue 64: a complex chromosome was read with its imaginary parts dropped, fractional
    layer sizes were truncated."""
    source = root / "results" / "paper" / "controllers" / "city" / "table4"
    with np.load(next(source.glob("*.npz"))) as saved:
        data = dict(saved)
    path = tmp_path / "edited.npz"
    np.savez(path, **(data | {field: edit(data[field])}))
    with pytest.raises(InputError) as error:
        Controller.load(path)
    assert error.value.key == field and message in error.value.message


def test_network_without_drivable_area_is_a_clear_error(tmp_path, root):
    net = tmp_path / "empty.net.xml"
    net.write_text('<net version="1.20"><location netOffset="0.00,0.00" '
                   'convBoundary="0,0,1,1" origBoundary="0,0,1,1" projParameter="!"/></net>')
    scenario = tmp_path / "s.toml"
    scenario.write_text(f'name = "empty"\n[track]\nnet = "{net}"\nstart_xy = [0.0, 0.0]\n')
    result = _run("run", scenario, "--generations", 1, "--out", tmp_path / "out")
    assert result.returncode == 2
    assert "empty.net.xml" in result.stderr and "no drivable area" in result.stderr
    assert "Traceback" not in result.stderr


# Hypothesis: a valid scenario with one value replaced by anything TOML can hold.
VALID = {
    "name": "prop", "seed": 1,
    "track": {"net": "NET", "start_xy": [20.0, 50.0], "start_heading_deg": 0.0},
    "vehicle": {"length": 4.3, "width": 2.5, "wheelbase": 2.6, "speed": 10.0, "dt": 0.1},
    "sensor": {"beams": 5, "span_deg": 180.0, "range": 25.0},
    "network": {"hidden": [3], "steering_gain_deg": 90.0, "layout": "source"},
    "ga": {"population_size": 10, "generations": 2, "tournament_size": 3,
           "mutation_probability": 0.1, "elite_count": 1},
    "episode": {"max_steps": 100, "spin_window": 49, "spin_variance": 64.0},
    "traffic": {"strategy": "straight", "starts_xy": [[40.0, 50.0]], "episodes": 1,
                "circle_radius": [15.0, 46.0]},
}
PLACES = [(section, key) for section, values in VALID.items() if isinstance(values, dict)
          for key in values] + [("", "name"), ("", "seed"), ("", "no_such_key"),
                                ("ga", "no_such_key")]
VALUES = st.one_of(
    st.none(), st.booleans(), st.integers(-10**12, 10**12),
    st.floats(allow_nan=True, allow_infinity=True), st.text(max_size=12),
    st.lists(st.floats(-1e3, 1e3), max_size=3), st.dictionaries(st.text(max_size=4),
                                                                st.integers(), max_size=2))


@settings(max_examples=150, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(place=st.sampled_from(PLACES), value=VALUES)
def test_any_edited_value_loads_or_names_file_and_key(tmp_path, root, place, value):
    data = {k: dict(v) if isinstance(v, dict) else v for k, v in VALID.items()}
    data["track"]["net"] = str(root / "sumo_nets" / "arena.net.xml")
    section, key = place
    target = data if not section else data[section]
    if value is None:
        target.pop(key, None)
    else:
        target[key] = value
    path = tmp_path / "prop.toml"
    try:
        path.write_text(tomli_w.dumps(data))
    except (TypeError, ValueError):
        return  # not writable as TOML (NaN keys and the like): nothing a user could save
    try:
        scenario = load_scenario(path)
    except InputError as error:
        assert error.file == str(path.resolve()) or error.file == str(path)
        assert error.key, error
        return
    assert scenario.name  # loaded: the edited value was a valid one
    assert not (isinstance(value, float) and not math.isfinite(value)), f"{place}: {value}"


def test_a_path_with_a_nul_character_names_file_and_key(tmp_path, root):
    """Found by the property test above: ``net = "\\u0000"`` reached pathlib's ValueError."""
    data = {k: dict(v) if isinstance(v, dict) else v for k, v in VALID.items()}
    data["track"]["net"] = "\x00"
    path = tmp_path / "nul.toml"
    path.write_text(tomli_w.dumps(data))
    with pytest.raises(InputError) as error:
        load_scenario(path)
    assert error.value.key == "net" and "path" in error.value.message


def test_bad_scenarios_from_the_command_line_exit_2_without_traceback(tmp_path, root):
    """A sample of the broken files the property test tries, through the real command line."""
    cases = {"beams": ("sensor", "beams", -1), "speed": ("vehicle", "speed", "fast"),
             "nan": ("sensor", "range", float("nan")), "extra": ("ga", "colour", 3),
             "strategy": ("traffic", "strategy", "teleport")}
    for name, (section, key, value) in cases.items():
        data = {k: dict(v) if isinstance(v, dict) else v for k, v in VALID.items()}
        data["track"]["net"] = str(root / "sumo_nets" / "arena.net.xml")
        data[section][key] = value
        path = tmp_path / f"{name}.toml"
        path.write_text(tomli_w.dumps(data))
        result = _run("run", path, "--out", tmp_path / name)
        assert result.returncode == 2, name
        assert f"{section}.{key}" in result.stderr and "Traceback" not in result.stderr, name


def test_a_run_started_with_sigint_ignored_still_stops_on_kill_int(tmp_path, root):
    """A script's background job (``enn-traffic run ... &``) inherits SIGINT ignored:
    ``kill -INT`` stops it anyway, with exit status 130 and the run's own message."""
    command = [sys.executable, "-m", "enn_traffic", "run", root / "scenarios" /
               "arena_strategy1.toml", "--out", tmp_path / "run", "--population", 40,
               "--generations", 100000, "--quiet"]
    process = subprocess.Popen(list(map(str, command)), stdout=subprocess.DEVNULL,
                               stderr=subprocess.PIPE, text=True,
                               preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_IGN))
    deadline = time.monotonic() + 120
    # a generation's row is written just before its checkpoint: wait for both
    while _generation_done(tmp_path / "run") < 1 or not (tmp_path / "run" / CHECKPOINT).exists():
        assert time.monotonic() < deadline and process.poll() is None, "it never got going"
        time.sleep(0.05)
    process.send_signal(signal.SIGINT)
    assert process.wait(timeout=30) == 130
    assert "continue with --resume" in process.stderr.read()


def test_a_locale_without_utf8_runs_every_command_and_shows_any_path(tmp_path):
    """Under LC_ALL=C without Python's UTF-8 mode every command died at import (a source file
    read without an encoding); with a terminal in latin-1, a file written under a path of
    Greek letters ended the command with UnicodeEncodeError after the work was done. Now
    ``--help`` runs, and ``lanes --out`` writes its file, says where (escaped) and exits 0."""
    import os

    c_locale = {**os.environ, "LC_ALL": "C", "PYTHONUTF8": "0", "PYTHONCOERCECLOCALE": "0"}
    done = subprocess.run([sys.executable, "-m", "enn_traffic", "--help"], env=c_locale,
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    out = tmp_path / "Ωμέγα.csv"
    latin = {**os.environ, "PYTHONIOENCODING": "latin-1"}
    done = subprocess.run([sys.executable, "-m", "enn_traffic", "lanes", "street_mixed",
                           "--top", "2", "--out", str(out)], env=latin, capture_output=True,
                          timeout=300)
    assert done.returncode == 0, done.stderr
    assert out.is_file() and b"\\u03a9" in done.stdout
    # a path given as bytes the C locale cannot decode is printed as those bytes, so that it
    # pastes back (it was printed \\udcc3\\udcbc)
    given = os.fsencode(tmp_path) + b"/o\xc3\xbc.csv"
    done = subprocess.run([sys.executable, "-m", "enn_traffic", "lanes", "street_mixed",
                           "--top", "2", "--out", given], env=c_locale, capture_output=True,
                          timeout=300)
    assert done.returncode == 0, done.stderr
    assert given in done.stdout and (tmp_path / "oü.csv").is_file()


def test_sumo_reads_a_path_of_any_letters_under_the_c_locale(tmp_path, road_net):
    """Under LC_ALL=C (Python then reads paths as UTF-8) SUMO took a scenario folder named
    with "ü" for a missing file: "File ... is not accessible (No such file or directory)",
    exit 2. Now SUMO and its tools get the C.UTF-8 locale for characters, and it runs."""
    import os

    from sumo_road import road_scenario

    folder = tmp_path / "straße ü"
    folder.mkdir()
    scenario = road_scenario(folder, road_net)
    best = Path(__file__).resolve().parents[2] / "results/paper/controllers/table1/strategy1.npz"
    done = subprocess.run([sys.executable, "-m", "enn_traffic", "evaluate", str(best),
                           str(scenario), "--quiet"], env={**os.environ, "LC_ALL": "C"},
                          capture_output=True, text=True, timeout=300, cwd=folder)
    assert done.returncode == 0, done.stderr


def test_a_population_of_one_is_refused_without_a_note_before(tmp_path, root, capsys):
    """``--population 1`` said the tournament was lowered to 1 and then refused the
    population naming the file's key: now the refusal alone, naming --population and its
    bounds (ga.population_size's)."""
    result = _run("run", root / "scenarios" / "navigation_narrow.toml", "--population", "1",
                  "--out", tmp_path / "run")
    assert result.returncode == 2
    error = result.stderr.strip().splitlines()[-1]
    assert "--population" in error and "from 2 to 100,000" in error
    assert "lowered" not in result.stderr and not (tmp_path / "run").exists()


def test_kernels_never_compile_into_the_package_when_the_cache_folder_is_unusable(tmp_path):
    """With ENN_TRAFFIC_CACHE naming a file, numba wrote its kernels into the package's own
    __pycache__ folders (the checkout, or site-packages); now into a folder of the temporary
    folder, which one line names, and nothing new lands beside the sources."""
    import os

    import enn_traffic

    package = Path(enn_traffic.__file__).parent
    started = time.time()
    blocker = tmp_path / "a_file"
    blocker.write_text("not a folder")
    script = ("import os, enn_traffic\nfrom enn_traffic.sim.safety import time_to_contact\n"
              "import numpy as np\nbox = np.array([[0., 0.], [1., 0.], [1., 1.], [0., 1.]])\n"
              "time_to_contact(box, box + 5.0, -1.0, -1.0)\nprint(os.environ['NUMBA_CACHE_DIR'])")
    env = {**os.environ, "ENN_TRAFFIC_CACHE": str(blocker), "TMPDIR": str(tmp_path)}
    env.pop("NUMBA_CACHE_DIR", None)
    done = subprocess.run([sys.executable, "-c", script], env=env, capture_output=True,
                          text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    folder = Path(done.stdout.strip().splitlines()[-1])
    assert folder.is_dir() and folder.is_relative_to(tmp_path)
    assert any(folder.rglob("*.nbi"))
    # said, not silent: the folder left in the temporary folder is named, once
    notes = [line for line in done.stderr.splitlines() if line.startswith("enn-traffic: note:")]
    assert len(notes) == 1 and str(folder) in notes[0] and "ENN_TRAFFIC_CACHE" in notes[0]
    assert not [p for p in package.rglob("*.nbi") if p.stat().st_mtime >= started]


def test_kernels_never_compile_into_the_package_when_numba_is_imported_first(tmp_path):
    """A program that imports numba (or a library that does) before enn_traffic: numba read
    its cache setting at its own import, and wrote every kernel into the package's own
    __pycache__ folders; now they go to the project's cache folder."""
    import os

    import enn_traffic

    package = Path(enn_traffic.__file__).parent
    started = time.time()
    script = ("import numba, os, enn_traffic\nfrom enn_traffic.sim.safety import "
              "time_to_contact\nimport numpy as np\n"
              "box = np.array([[0., 0.], [1., 0.], [1., 1.], [0., 1.]])\n"
              "time_to_contact(box, box + 5.0, -1.0, -1.0)\nprint(os.environ['NUMBA_CACHE_DIR'])")
    env = {**os.environ, "ENN_TRAFFIC_CACHE": str(tmp_path / "cache")}
    env.pop("NUMBA_CACHE_DIR", None)
    done = subprocess.run([sys.executable, "-c", script], env=env, capture_output=True,
                          text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    folder = Path(done.stdout.strip().splitlines()[-1])
    assert folder.is_relative_to(tmp_path / "cache") and any(folder.rglob("*.nbi"))
    assert not [p for p in package.rglob("*.nbi") if p.stat().st_mtime >= started]


@pytest.mark.parametrize("executor", ["process", pytest.param("ray", marks=pytest.mark.full)])
def test_a_worker_killed_mid_run_is_one_line_and_resume_gives_the_uninterrupted_run(
        tmp_path, root, executor):
    """SIGKILL to a process-pool worker or a Ray actor between generations 2 and 12 (as the
    OOM killer would): the run ends in one line naming the dead worker and how to go on, no
    traceback, exit 1 (it was the pool's raw BrokenProcessPool traceback, Ray's
    ActorDiedError); --resume gives the run never disturbed."""
    scenario = root / "scenarios" / "arena_strategy1.toml"
    whole = tmp_path / "whole"
    assert _run("run", scenario, "--out", whole, *RUN).returncode == 0
    broken = tmp_path / "broken"
    process = _run("run", scenario, "--out", broken, "--executor", executor, *RUN, wait=False)
    find = (["pgrep", "-P", str(process.pid), "-f", "spawn_main"] if executor == "process"
            else ["pgrep", "-f", "ray::_WorldActor"])
    deadline = time.monotonic() + 300
    workers: list[str] = []
    while process.poll() is None and time.monotonic() < deadline:
        if _generation_done(broken) >= 2:
            workers = subprocess.run(find, capture_output=True, text=True).stdout.split()
            if workers:
                break
        time.sleep(0.01)
    assert workers, "no worker to kill before the run ended"
    subprocess.run(["kill", "-9", workers[0]], check=False)
    stderr = process.communicate(timeout=120)[1].decode()
    assert process.returncode == 1, stderr
    assert "a worker process died" in stderr and "--resume" in stderr
    assert "Traceback" not in stderr
    resumed = _run("run", scenario, "--out", broken, "--executor", executor, "--resume", *RUN)
    assert resumed.returncode == 0, resumed.stderr
    assert_same_run(whole, broken)


@pytest.mark.parametrize("name, what", [("checkpoint.npz", "a run"),
                                        ("crowd.toml", "a crowd run")])
def test_baseline_never_mixes_its_files_into_a_run_or_a_crowd(tmp_path, capsys, name, what):
    """``baseline --out`` into a finished run's or crowd's folder wrote its comparison among
    their files, where ``run`` and ``crowd`` refuse each other's folders: now refused too."""
    from enn_traffic.cli import main

    out = tmp_path / "taken"
    out.mkdir()
    (out / name).write_bytes(b"theirs")
    assert main(["baseline", "arena_strategy1", "--plan", "GA:1M:1", "--out", str(out),
                 "--quiet"]) == 2
    assert f"holds {what}" in capsys.readouterr().err
    assert sorted(p.name for p in out.iterdir()) == [name]
