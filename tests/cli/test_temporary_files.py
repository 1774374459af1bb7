"""No temporary file or folder survives a process that starts SUMO: each exit path (a command
that ends, a closed-loop environment closed, left open, or abandoned by an exception) runs in a
temporary folder of the test's own (TMPDIR), which must be empty afterwards. (Ctrl-C of a
closed-loop evaluation: tests/cli/test_adversarial.py; a killed process's folder is swept by
the next SUMO start: tests/sumo.)"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
BEST = ROOT / "results/paper/controllers/table1/strategy1.npz"


def _closed_loop(tmp_path: Path, road_net: Path) -> Path:
    from sumo_road import road_scenario

    return road_scenario(tmp_path, road_net, extra='mode = "closed-loop"')


def _in_own_temp(tmp_path: Path, argv: list[str]) -> tuple[subprocess.CompletedProcess, list]:
    """Run ``argv`` with TMPDIR a fresh folder; its result, and what the folder holds after."""
    temp = tmp_path / "temp"
    temp.mkdir(exist_ok=True)
    done = subprocess.run([sys.executable, *argv], cwd=tmp_path, capture_output=True,
                          text=True, env={**os.environ, "TMPDIR": str(temp)}, timeout=300)
    return done, sorted(p.name for p in temp.iterdir())


@pytest.mark.parametrize("command", ["evaluate", "render", "lanes"])
def test_a_command_that_ends_leaves_no_temporary_folder(tmp_path, road_net, command):
    scenario = _closed_loop(tmp_path, road_net)
    argv = {"evaluate": ["evaluate", BEST, scenario, "--quiet"],
            "render": ["render", BEST, scenario, "--out", tmp_path / "drive.png"],
            "lanes": ["lanes", tmp_path / "road.sumocfg"]}[command]
    done, left = _in_own_temp(tmp_path, ["-m", "enn_traffic", *map(str, argv)])
    assert done.returncode == 0, done.stderr
    assert left == []


# A user's script with closed-loop environments: how it ends, as Python lines after one env
# was reset and stepped.
ENDINGS = {
    "closed": ("env.close()", 0),
    "left open": ("", 0),
    "an exception": ("raise RuntimeError('the user script failed')", 1),
    "a second live env refused": ("second = gymnasium.make(ID, scenario=SCENARIO)\n"
                                  "second.reset(seed=2)", 1),
}


@pytest.mark.parametrize("ending", list(ENDINGS))
def test_a_closed_loop_environment_leaves_no_sumo_folder_however_its_script_ends(
        tmp_path, road_net, ending):
    """A live env left open as its script ended kept its ``enn-sumo-*`` folder (as did the
    first of two live envs when the second was refused): SUMO now closes when the process
    ends."""
    scenario = _closed_loop(tmp_path, road_net)
    lines, status = ENDINGS[ending]
    script = ("import gymnasium\nimport enn_traffic.envs\n"
              f"ID, SCENARIO = 'enn_traffic/Scenario-v0', {str(scenario)!r}\n"
              "env = gymnasium.make(ID, scenario=SCENARIO)\n"
              "env.reset(seed=1)\nenv.step(env.action_space.sample())\n" + lines + "\n")
    done, left = _in_own_temp(tmp_path, ["-c", script])
    assert done.returncode == status, done.stderr
    assert left == []
