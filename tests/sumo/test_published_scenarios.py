"""SUMO scenarios as their publishers ship them (docs/sumo.md): the road surface is the cars'
(sidewalks, bike lanes and tram tracks are not road); the scenario is read, never written
(SUMO's outputs, logs and console go to the run's folder or nowhere); a ``.sumocfg``'s GUI-only
options and every missing file are dealt with before SUMO starts; and a collision says what it
was with. The shipped street (scenarios/street_mixed.toml) has all of these features."""

import numpy as np
import pandas as pd
import pytest
from sumo_road import CONFIG, road_scenario

from enn_traffic.cli import main
from enn_traffic.config import load_scenario
from enn_traffic.roads import load_track
from enn_traffic.runs.controller import Controller
from enn_traffic.sumo.command import LEARNER
from enn_traffic.sumo.states import warm_state

# The road's .sumocfg as publishers ship theirs: a <sumoConfiguration> root, outputs, a log,
# SUMO's verbose console, a detector writing its own file, and a GUI settings file that is not
# there.
PUBLISHED = """<sumoConfiguration>
    <input>
        <net-file value="road.net.xml"/>
        <route-files value="buses.rou.xml"/>
        <additional-files value="detectors.add.xml"/>
    </input>
    <time><begin value="1000"/></time>
    <output>
        <tripinfo-output value="tripinfos.xml"/>
        <summary-output value="{absolute}"/>
    </output>
    <report>
        <verbose value="true"/>
        <duration-log.statistics value="true"/>
        <log value="sumo_log.txt"/>
    </report>
    <gui_only>
        <gui-settings-file value="settings.gui.xml"/>
    </gui_only>
</sumoConfiguration>"""
DETECTORS = """<additional>
    <inductionLoop id="loop" lane="ew_0" pos="50" period="10" file="loop.xml"/>
</additional>"""


def published(folder, road_net, extra=""):
    """The road scenario in ``folder`` with the :data:`PUBLISHED` configuration."""
    folder.mkdir(exist_ok=True)
    path = road_scenario(folder, road_net, extra=extra)
    (folder / "road.sumocfg").write_text(PUBLISHED.format(absolute=folder / "summary.xml"))
    (folder / "detectors.add.xml").write_text(DETECTORS)
    return path


def snapshot(folder):
    return {p.relative_to(folder): (p.stat().st_size, p.stat().st_mtime_ns)
            for p in folder.rglob("*")}


def test_the_street_is_road_for_cars_only(root):
    """Across the main street at x = 50 (eastbound from the kerb at y = -9.7: a 2 m sidewalk, a
    1.5 m bike lane, a 3.2 m car lane, a 3 m tram track; westbound mirrored), only the car
    lanes' centres (y = -4.6 and 4.6) are road; with ``surface = "all"`` every lane is; the
    junction, where cars cross, is road either way."""
    net = root / "scenarios" / "street" / "street.net.xml.gz"
    centres = (-8.7, -6.95, -4.6, -1.5, 1.5, 4.6, 6.95, 8.7)
    cars = load_track(net, exits=True)
    assert [cars.contains(50.0, y) for y in centres] == [False, False, True, False,
                                                          False, True, False, False]
    every = load_track(net, exits=True, surface="all")
    assert all(every.contains(50.0, y) for y in centres)
    assert cars.contains(150.0, 0.0) and every.contains(150.0, 0.0)
    assert (len(cars.exits), len(every.exits)) == (6, 4)  # each car way's end, or each road's


def test_the_shipped_street_is_run_evaluated_and_drawn_without_being_written(root, tmp_path):
    """The shipped street through ``run``, ``evaluate --mode closed-loop`` and ``render``: its
    folder is byte for byte as it was (no tripinfo, log or detector file, though its .sumocfg
    asks for them, and its missing GUI settings file stopped nothing); the start lane
    ``auto`` chose is the busiest car lane."""
    folder = root / "scenarios" / "street"
    before = snapshot(folder)
    run = tmp_path / "run"
    assert main(["run", "street_mixed", "--out", str(run), "--generations", "1",
                 "--population", "10", "--quiet"]) == 0
    assert 'start_lane = "ec_2"' in (run / "scenario.toml").read_text()
    log = (run / "sumo" / "sumo.log").read_text()  # a block per start, though SUMO said nothing
    assert log.count("== SUMO, seed") >= 1 and "(SUMO printed nothing)" in log
    assert main(["evaluate", str(run / "best.npz"), str(root / "scenarios" / "street_mixed.toml"),
                 "--mode", "closed-loop", "--out", str(tmp_path / "eval.csv"), "--quiet"]) == 0
    assert main(["render", str(run / "best.npz"), "street_mixed",
                 "--out", str(tmp_path / "street.png"), "--quiet"]) == 0
    assert (tmp_path / "street.png").read_bytes()[:4] == b"\x89PNG"
    assert snapshot(folder) == before


def test_a_run_and_a_closed_loop_evaluate_leave_the_scenario_folder_as_it_was(
        tmp_path, road_net, capfd):
    """``run`` and ``evaluate --mode closed-loop`` on a published-style .sumocfg: nothing in
    the scenario's folder is written (not its outputs, its log, its detector's file, nor the
    absolute path it names), the missing GUI settings file does not stop SUMO, and SUMO's
    verbose console goes to the run's sumo/sumo.log, not the terminal."""
    path = published(tmp_path / "scenario", road_net)
    before = snapshot(tmp_path / "scenario")
    run = tmp_path / "run"
    assert main(["run", str(path), "--out", str(run), "--generations", "2",
                 "--population", "10", "--quiet"]) == 0
    assert main(["evaluate", str(run / "best.npz"), str(path), "--mode", "closed-loop",
                 "--out", str(tmp_path / "eval.csv"), "--quiet"]) == 0
    assert snapshot(tmp_path / "scenario") == before
    console = capfd.readouterr()
    assert "Loading net-file" not in console.out + console.err
    log = (run / "sumo" / "sumo.log").read_text()
    assert "Loading net-file" in log and log.count("== SUMO, seed") >= 2
    assert "Loading net-file" in (tmp_path / "eval_sumo" / "sumo.log").read_text()
    assert not (run / "sumo" / "outputs").exists()  # traffic.sumo_outputs = "off"


def test_kept_outputs_go_to_the_run_folder(tmp_path, road_net):
    """``traffic.sumo_outputs = "keep"``: each SUMO start's outputs (the .sumocfg's and its
    detector's) are kept in a folder of their own under the run's sumo/outputs/."""
    path = published(tmp_path / "scenario", road_net, extra='sumo_outputs = "keep"')
    run = tmp_path / "run"
    assert main(["run", str(path), "--out", str(run), "--generations", "1",
                 "--population", "10", "--quiet"]) == 0
    starts = sorted((run / "sumo" / "outputs").iterdir())
    assert len(starts) == 2  # the generation's two situations
    for start in starts:
        names = {p.name for p in start.iterdir()}
        assert {"tripinfos.xml", "summary.xml", "loop.xml", "sumo_log.txt"} <= names
        assert "<tripinfos" in (start / "tripinfos.xml").read_text()


def test_a_shared_warm_up_keeps_no_outputs_and_is_simulated_once(tmp_path, road_net,
                                                                  monkeypatch):
    """With a shared warm-up (``warmup_states = 1``), the two situations' outputs are kept,
    not the warm-up's (it holds no situation: its files would be empty); two processes that
    need the warm-up at once simulate it once (SUMO's log holds one start that ended at the
    warm-up's end, 10 s after the begin), the other waiting for it."""
    from concurrent.futures import ProcessPoolExecutor
    from multiprocessing import get_context

    monkeypatch.setenv("ENN_TRAFFIC_SUMO_STATES", str(tmp_path / "states"))
    path = published(tmp_path / "scenario", road_net,
                     extra='sumo_outputs = "keep"\nwarmup_states = 1')
    run = tmp_path / "run"
    assert main(["run", str(path), "--out", str(run), "--generations", "1",
                 "--population", "10", "--quiet"]) == 0
    assert len(list((run / "sumo" / "outputs").iterdir())) == 2  # the situations' alone
    monkeypatch.setenv("ENN_TRAFFIC_SUMO_STATES", str(tmp_path / "states_again"))
    scenario = load_scenario(path).with_sumo_output(tmp_path / "both")
    with ProcessPoolExecutor(2, mp_context=get_context("spawn")) as pool:
        states = list(pool.map(warm_state, [scenario] * 2, [7] * 2, [False] * 2))
    assert states[0] == states[1] and states[0].is_file()
    log = (tmp_path / "both" / "sumo.log").read_text()
    assert log.count("== SUMO, seed 7, ended at 1010 s") == 1


def test_loading_a_warm_up_begins_at_its_time_without_a_warning(tmp_path, road_net, capfd,
                                                                 monkeypatch):
    """SUMO warns when a state's time is not the begin ("State was written at a different
    time"), on every load with its console shown (``--verbose``): the command begins at the
    state's time, 10 s after the .sumocfg's begin, and SUMO says nothing."""
    from enn_traffic.sumo.command import state_time
    from enn_traffic.sumo.simulation import Simulation

    monkeypatch.setenv("ENN_TRAFFIC_SUMO_STATES", str(tmp_path / "states"))
    scenario = load_scenario(road_scenario(tmp_path, road_net))
    state = warm_state(scenario, 7, keep_rng=False)
    assert state_time(state) == "1010.00"
    capfd.readouterr()
    simulation = Simulation(scenario.with_sumo_output(None, console=True), 7, state)
    assert simulation.time() == pytest.approx(1010.0)
    simulation.close()
    assert "different time" not in "".join(capfd.readouterr())


def test_every_missing_file_is_named_at_once(tmp_path, road_net, capsys):
    path = road_scenario(tmp_path, road_net)
    (tmp_path / "road.sumocfg").write_text(
        CONFIG.format(begin=0, end="")
        .replace("buses.rou.xml", "buses.rou.xml,gone.rou.xml")
        .replace("</input>", '<additional-files value="lights.add.xml,stops.add.xml"/></input>'))
    assert main(["run", str(path), "--out", str(tmp_path / "run"), "--quiet"]) == 2
    error = capsys.readouterr().err
    assert "road.sumocfg: route-files, additional-files: names 3 files that do not exist" in error
    assert all(name in error for name in ("gone.rou.xml", "lights.add.xml", "stops.add.xml"))
    assert not (tmp_path / "run").exists()
    (tmp_path / "road.sumocfg").write_text(
        CONFIG.format(begin=0, end="").replace("buses.rou.xml", "buses.rou.xml,gone.rou.xml"))
    assert main(["run", str(path), "--out", str(tmp_path / "run"), "--quiet"]) == 2
    error = capsys.readouterr().err  # one file of one option: the option named once
    assert "road.sumocfg: route-files: names a file that does not exist: gone.rou.xml (" in error


@pytest.mark.parametrize("mode", ["replay", "closed-loop"])
def test_a_collision_says_what_it_was_with(tmp_path, road_net, mode):
    """A straight driver on the westbound lane facing east meets the westbound buses head on:
    its collision is with a vehicle, named by its SUMO id and type; facing north from the
    eastbound lane, it runs into the road's edge: a wall. Each row says where and when: the
    front bumper's x, y where a straight line at the vehicle's speed puts it, the lane nearest
    it, and the time SUMO's outputs label that step (the .sumocfg's begin at 1000 s, 12 s of
    warm-up, then its steps less one): in closed loop SUMO's own fcd output puts the learner
    there at that time, and there it ends."""
    rows = {}
    for name, start in (("bus", "start_xy = [20.0, 2.0]\nstart_heading_deg = 0.0"),
                        ("edge", "start_xy = [20.0, 0.5]\nstart_heading_deg = 90.0")):
        folder = tmp_path / name
        folder.mkdir()
        scenario = load_scenario(road_scenario(folder, road_net, start=start, warmup=12.0,
                                               extra='outputs = ["fcd"]'))
        controller = folder / "straight.npz"
        length = len(np.zeros(19 * 3 + 3 + 3 * 2 + 2))
        Controller.from_scenario(scenario, np.zeros(length), 0.0, 0).save(controller)
        out = folder / "eval.csv"
        assert main(["evaluate", str(controller), str(folder / "scenario.toml"),
                     "--mode", mode, "--out", str(out), "--quiet"]) == 0
        rows[name] = pd.read_csv(out, keep_default_na=False).iloc[0]
    speed, dt = scenario.vehicle.speed, scenario.vehicle.dt
    for name, (x, y, heading) in (("bus", (20.0, 2.0, 0.0)), ("edge", (20.0, 0.5, 90.0))):
        row, moved = rows[name], rows[name]["steps"] * speed * dt
        assert row["end_x_m"] == pytest.approx(x + moved * np.cos(np.radians(heading)), abs=0.01)
        assert row["end_y_m"] == pytest.approx(y + moved * np.sin(np.radians(heading)), abs=0.01)
        assert row["end_sumo_time_s"] == pytest.approx(1012.0 + (row["steps"] - 1) * dt)
        if mode == "closed-loop":
            starts = list((tmp_path / name).glob("eval_sumo/outputs/*/fcd.xml"))
            assert len(starts) == 1  # the situation's: no check's, no warm-up's
            fcd = starts[0].read_text()
            last = fcd.rpartition("<timestep")[2]
            assert f'time="{row["end_sumo_time_s"]:.2f}"' in last
            learner = last.partition(f'id="{LEARNER}"')[2]
            assert f'x="{row["end_x_m"]:.2f}"' in learner
    assert (rows["bus"]["end_edge"], rows["bus"]["end_lane"]) == ("ew", "ew_0")
    assert rows["edge"]["end_lane"] == ("we_0" if rows["edge"]["end_y_m"] < 0 else "ew_0")
    assert rows["bus"]["outcome"] == "collision" and rows["bus"]["hit"] == "vehicle"
    assert rows["bus"]["hit_vehicle"].startswith("bus.") and rows["bus"]["hit_type"] == "bus"
    assert rows["edge"]["outcome"] == "collision" and rows["edge"]["hit"] == "wall"
    assert rows["edge"]["hit_vehicle"] == "" and rows["edge"]["steps"] < 5


def test_an_unwritable_warm_up_folder_keeps_warm_ups_in_the_temporary_folder(
        tmp_path, road_net, monkeypatch):
    """ENN_TRAFFIC_SUMO_STATES naming a file (a folder that cannot be written): a SUMO run
    stopped with "Permission denied" or "Not a directory", where an unwritable walls cache is
    tolerated; the warm-up is saved in the temporary folder instead, and loads."""
    import tempfile

    blocker = tmp_path / "a_file"
    blocker.write_text("not a folder")
    monkeypatch.setenv("ENN_TRAFFIC_SUMO_STATES", str(blocker))
    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path / "tmp"))
    (tmp_path / "tmp").mkdir()
    scenario = load_scenario(road_scenario(tmp_path, road_net))
    state = warm_state(scenario, 7, keep_rng=False)
    assert state.is_file() and state.is_relative_to(tmp_path / "tmp")
