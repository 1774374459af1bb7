"""Refusals of input a command cannot use, each one line naming what is at fault, exit 2,
before any folder is made: a Ray address without Ray, a scenario whose paths a TOML file
cannot hold, a population too large for memory."""

import subprocess
import sys

import pytest

from enn_traffic.core.errors import InputError


def _run(*args):
    return subprocess.run([sys.executable, "-m", "enn_traffic", *map(str, args)],
                          capture_output=True, text=True)


def test_a_scenario_in_a_folder_named_by_bytes_not_utf8_is_refused_naming_the_key(
        tmp_path, root):
    """A folder whose name is bytes that are not UTF-8 (Linux allows them) cannot go into a
    run's scenario.toml: ``run`` refuses it in one line naming the scenario's key, exit 2,
    before making its folder (it was a UnicodeEncodeError traceback, exit 1)."""
    import os
    import shutil

    folder = tmp_path / os.fsdecode(b"n\xffdir")
    folder.mkdir()
    shutil.copy(root / "sumo_nets" / "track_narrow.net.xml", folder)
    text = (root / "scenarios" / "navigation_narrow.toml").read_text(encoding="utf-8")
    (folder / "sc.toml").write_text("\n".join(
        'net = "track_narrow.net.xml"' if line.startswith("net =") else line
        for line in text.splitlines()), encoding="utf-8")
    out = tmp_path / "out"
    done = subprocess.run([sys.executable, "-m", "enn_traffic", "run", folder / "sc.toml",
                           "--generations", "1", "--out", out], capture_output=True)
    assert done.returncode == 2
    error = done.stderr.strip().splitlines()[-1]  # the path as given: its own bytes
    assert bytes(folder / "sc.toml") in error
    assert b"track.net: names a file in a folder whose name is not UTF-8" in error
    assert not out.exists()


def test_a_population_too_large_for_memory_is_judged_with_the_command_lines_population(
        tmp_path, root, capsys):
    """The population's memory limit is a run's, on the resolved scenario: a network of
    1,072,130 genes loads (evaluate needs no population), 200 of it are refused before the
    run's folder is made, naming ga.population_size, and --population 4 fits (the limit was
    checked at loading, on the file's 200, whatever --population said)."""
    from enn_traffic.cli import main
    from enn_traffic.config import load_scenario

    text = (root / "scenarios" / "navigation_narrow.toml").read_text(encoding="utf-8")
    path = tmp_path / "huge.toml"
    path.write_text(text.replace('net = "../', f'net = "{root}/').replace(
        "hidden = [3]", "hidden = [1024, 1024]"), encoding="utf-8")
    scenario = load_scenario(path)
    assert scenario.ga.population_size == 200
    with pytest.raises(InputError, match="ga.population_size: 200 chromosomes of 1,072,130"):
        scenario.check_population_fits()
    scenario.with_overrides(ga={"population_size": 4, "tournament_size": 4}
                            ).check_population_fits()
    out = tmp_path / "out"
    assert main(["run", str(path), "--generations", "1", "--out", str(out)]) == 2
    assert "ga.population_size: 200 chromosomes" in capsys.readouterr().err
    assert not out.exists()


@pytest.mark.parametrize("command", ["run", "evaluate", "crowd", "reproduce"])
def test_a_ray_address_without_the_ray_executor_is_refused(tmp_path, command):
    """``--address`` is read by the Ray executor only: with another, every command that takes
    it refuses it in one line, exit 2 (it was silently ignored, the run local)."""
    args = {"run": ["navigation_narrow"], "evaluate": ["a.npz", "navigation_narrow"],
            "crowd": ["sumo_strategy1"], "reproduce": []}[command]
    done = _run(command, *args, "--out", tmp_path / "out", "--address", "auto")
    assert done.returncode == 2, done.stderr
    assert done.stderr.strip().splitlines() == [
        "enn-traffic: error: --address: a Ray cluster's address is used with --executor ray "
        "only (here --executor local)"]
    assert not (tmp_path / "out").exists()
