"""Users' own SUMO scenarios through a real libsumo: a ``.sumocfg`` run as SUMO runs it (its
begin time, its network), traffic that never comes refused, the network's fringe as an exit,
starts drawn from lanes and edges, warm-ups simulated once, and the city scenario that ships
with the project."""

import numpy as np
import pandas as pd
import pytest
from sumo_road import CONFIG, road_scenario, straight

from enn_traffic.cli import main
from enn_traffic.config import episode_steps, learner_start_time, load_scenario
from enn_traffic.core.errors import InputError
from enn_traffic.roads import load_track
from enn_traffic.sim.world import COLLIDED, LEFT_NETWORK, MET_START, make_world
from enn_traffic.sumo import states
from enn_traffic.sumo.simulation import Simulation


def test_sumocfg_begin_time_and_network_are_used(tmp_path, road_net):
    """The .sumocfg begins at 1000 s and the first bus departs then: the learner, 10 s later,
    meets traffic. (Started at 0 s, as SUMO was before, the network would be empty for 1000 s
    and nothing would be met.) [track] names no net: the .sumocfg's is the track."""
    scenario = load_scenario(road_scenario(tmp_path, road_net))
    assert scenario.track.net == (tmp_path / "road.net.xml").resolve()
    assert learner_start_time(scenario) == 1010.0
    world = make_world(scenario)
    results = world.evaluate(straight(world))
    assert (results.traffic[0, :, MET_START] == 1).all()  # the first bus, 10 s along
    assert results.traffic_summary()["traffic_near_max"] >= 1


def test_begin_s_overrides_the_sumocfg(tmp_path, road_net):
    scenario = load_scenario(road_scenario(tmp_path, road_net, begin=0.0, departs=500.0,
                                           extra="begin_s = 600.0"))
    assert learner_start_time(scenario) == 610.0
    world = make_world(scenario)
    assert world.evaluate(straight(world)).traffic[0, 0, MET_START] >= 1


def test_traffic_that_never_reaches_the_network_is_refused(tmp_path, road_net, capsys):
    """Buses depart from 5000 s on, the learner starts at 10 s and lives at most 40 s: `run`
    stops with exit status 2 and says why, naming the scenario and its traffic key."""
    path = road_scenario(tmp_path, road_net, begin=0.0, departs=5000.0)
    code = main(["run", str(path), "--out", str(tmp_path / "run"), "--quiet",
                 "--generations", "1", "--population", "10"])
    message = capsys.readouterr().err
    assert code == 2
    assert str(path) in message and "traffic.sumocfg" in message
    assert "no SUMO vehicle is on the network from 10 s to 50 s" in message
    assert "departures span 5000-5600 s" in message  # the flow's begin and end
    scenario = load_scenario(path).with_overrides(traffic={"mode": "closed-loop"})
    with pytest.raises(InputError, match="no SUMO vehicle"):
        make_world(scenario).evaluate(np.zeros((1, 19 * 3 + 3 + 3 * 2 + 2)))


def test_a_smaller_step_cap_still_refuses_traffic_a_longer_one_meets(tmp_path, road_net):
    """Buses depart 30 s (300 steps) after the learner starts. A world capped at 400 steps
    meets them and keeps its recording of the first 256 steps, which hold none yet; a world
    of the same traffic capped at 280 steps must refuse, not reuse that recording (kept
    recordings are keyed by the step cap too: docs/sumo.md, "Replay and closed loop")."""
    scenario = load_scenario(road_scenario(tmp_path, road_net, begin=0.0, departs=40.0))
    world = make_world(scenario)
    world.evaluate(straight(world))
    short = make_world(scenario.with_overrides(episode={"max_steps": 280}))
    with pytest.raises(InputError, match="no SUMO vehicle"):
        short.evaluate(straight(short))


def test_a_warm_up_past_the_last_departure_stops_once_sumo_is_empty(tmp_path, road_net,
                                                                   capsys):
    """Buses depart from 1000 s to 1600 s and cross the 200 m road in under 20 s; a warm-up
    of 20,000 s stops, exit status 2, once the last bus has left (SUMO time between 1600 s and
    1700 s), not after 20,000 SUMO seconds, and says why."""
    path = road_scenario(tmp_path, road_net, warmup=20000.0)
    code = main(["run", str(path), "--out", str(tmp_path / "run"), "--generations", "1",
                 "--population", "10"])
    message = capsys.readouterr().err
    assert code == 2
    assert "departures span 1000-1600 s" in message
    emptied = float(message.split("left the network at ")[1].split(" s")[0])
    assert 1600.0 < emptied < 1700.0, message


def test_an_output_in_a_missing_sub_folder_is_named_with_its_cause(tmp_path, road_net, capsys):
    """A detector writing to ``out/loops.xml`` where ``out/`` does not exist: SUMO prints
    the error rather than logging it, and the message said only "Process Error"."""
    path = road_scenario(tmp_path, road_net)
    (tmp_path / "loops.add.xml").write_text(
        '<additional><inductionLoop id="loop" lane="we_0" pos="50" period="60" '
        'file="out/loops.xml"/></additional>')
    config = tmp_path / "road.sumocfg"
    config.write_text(config.read_text().replace(
        "</input>", '<additional-files value="loops.add.xml"/></input>'))
    code = main(["run", str(path), "--out", str(tmp_path / "run"), "--quiet",
                 "--generations", "1", "--population", "10"])
    message = capsys.readouterr().err
    assert code == 2 and "Could not build output file" in message, message
    assert "sub-folder that does not exist" in message and "../../.." not in message
    assert not (tmp_path / "out").exists()  # the scenario's folder is never written


@pytest.mark.parametrize("mode", ["replay", "closed-loop"])
def test_reaching_the_fringe_is_leaving_the_network(tmp_path, road_net, mode):
    """A straight driver from x = 20 on the eastbound lane reaches the road's east end (x = 200)
    after 180 steps of 1 m. With SUMO traffic the fringe is an exit: "left network", not a
    collision; ``fringe = "wall"`` keeps it a wall."""
    ends = {}
    for fringe in ("", 'fringe = "wall"'):
        scenario = load_scenario(road_scenario(tmp_path, road_net, fringe=fringe)).with_overrides(
            traffic={"mode": mode})
        world = make_world(scenario)
        results = world.evaluate(straight(world))
        ends[fringe] = (int(results.steps[0, 0]), int(results.outcome[0, 0]))
    assert ends[""] == (180, LEFT_NETWORK)
    assert ends['fringe = "wall"'] == (180, COLLIDED)


def test_exits_lie_across_the_road_ends(road_net):
    """Every lane as road (``surface = "all"``): the exits are the two road ends, x = 0 and
    x = 200, across both lanes (y from -4 to 4); no wall is left there, and no exit
    elsewhere."""
    track = load_track(road_net, exits=True, surface="all")
    exits = sorted(tuple(np.round(row, 6)) for row in track.exits)
    assert len(exits) == 2
    for exit_row, x in zip(exits, (0.0, 200.0), strict=True):
        assert exit_row[0] == exit_row[2] == x
        assert sorted((exit_row[1], exit_row[3])) == [-4.0, 4.0]
    walls = load_track(road_net, surface="all").walls
    assert len(track.walls) == len(walls) - 2
    assert not ((track.walls[:, 0] == 200.0) & (track.walls[:, 2] == 200.0)).any()


def test_a_bus_lane_is_no_road_for_cars(road_net):
    """The learner's surface (``surface = "passenger"``, the default): the bus-only lane from
    x = 100 to 200 (y from 0 to 4) is not road, so a wall runs along y = 0 there, and the exit
    at x = 200 spans the eastbound lane alone (y from -4 to 0)."""
    track = load_track(road_net, exits=True)
    assert track.contains(150.0, -2.0) and not track.contains(150.0, 2.0)
    assert track.contains(50.0, 2.0)  # the westbound lane before x = 100 is for everyone
    along_middle = [w for w in np.round(track.walls, 6)
                    if w[1] == w[3] == 0.0 and min(w[0], w[2]) >= 100.0 - 1e-6]
    assert sum(abs(w[2] - w[0]) for w in along_middle) == pytest.approx(100.0, abs=0.5)
    east = [tuple(e) for e in np.round(track.exits, 6) if e[0] == e[2] == 200.0]
    assert len(east) == 1 and sorted((east[0][1], east[0][3])) == [-4.0, 0.0]


def test_fringe_exit_needs_sumo_traffic(tmp_path, road_net):
    path = tmp_path / "alone.toml"
    path.write_text(f'name = "alone"\n[track]\nnet = "{road_net}"\nstart_lane = "we_0"\n'
                    'fringe = "exit"\n')
    with pytest.raises(InputError, match="needs SUMO traffic") as error:
        load_scenario(path)
    assert error.value.key == "track.fringe"


def test_starts_are_drawn_per_situation_from_lanes_and_edges(tmp_path, road_net):
    """Two start edges: each situation starts on one of them (the rightmost lane that allows
    cars, 20 m along), the same for every chromosome, and over generations on both."""
    path = road_scenario(tmp_path, road_net, start='start_edge = ["we", "me"]')
    world = make_world(load_scenario(path))
    assert [tuple(np.round(p, 6)) for p in world.starts] == [(20.0, -2.0, 0.0), (120.0, -2.0, 0.0)]
    drawn = {tuple(start) for g in range(8) for start in world.situation_starts(g)}
    assert len(drawn) == 2
    again = make_world(load_scenario(path))  # the draw depends on the situation alone
    assert [s.tolist() for s in world.situation_starts(3)] == [
        s.tolist() for s in again.situation_starts(3)]


@pytest.mark.parametrize(("start", "key", "message"), [
    ('start_lane = "em_0"', "track.start_lane", "does not allow passenger cars"),
    ('start_edge = ["we", "nope"]', "track.start_edge[1]", "no edge 'nope'"),
    ('start_lane = ["we_0", "we_7"]', "track.start_lane[1]", "no lane 'we_7'"),
    ('start_edge = "em"', "track.start_edge", "no lane of edge 'em' allows passenger cars"),
])
def test_bad_starts_are_named(tmp_path, road_net, capsys, start, key, message):
    path = road_scenario(tmp_path, road_net, start=start)
    assert main(["run", str(path), "--out", str(tmp_path / "run"), "--quiet"]) == 2
    error = capsys.readouterr().err
    assert f"{path}: {key}: " in error and message in error


@pytest.mark.parametrize(("config", "option", "message"), [
    (CONFIG.replace("buses.rou.xml", "missing.rou.xml"), "route-files", "missing.rou.xml"),
    (CONFIG.replace("road.net.xml", "nowhere.net.xml"), "net-file", "nowhere.net.xml"),
    (CONFIG.format(begin=100, end='<end value="50"/>'), "end", "not after begin"),
    (CONFIG.replace("</input>", '<additional-files value="lights.add.xml"/></input>'),
     "additional-files", "lights.add.xml"),
    (CONFIG.format(begin="x7", end=""), "begin", "not a SUMO time"),
])
def test_bad_sumocfg_is_named(tmp_path, road_net, capsys, config, option, message):
    path = road_scenario(tmp_path, road_net)
    (tmp_path / "road.sumocfg").write_text(config.format(begin=0, end=""))
    assert main(["run", str(path), "--out", str(tmp_path / "run"), "--quiet"]) == 2
    error = capsys.readouterr().err
    assert f"road.sumocfg: {option}: " in error and message in error


TRIPS = """<routes>
    <vTypeDistribution id="mix">
        <vType id="small" vClass="bus" length="8" width="2.3" probability="0.5"/>
        <vType id="large" vClass="bus" length="14" width="2.5" probability="0.5"/>
    </vTypeDistribution>
    <trip id="t0" type="mix" depart="1000" from="em" to="ew" departSpeed="max"/>
    <trip id="t1" type="mix" depart="1004" from="em" to="ew" departSpeed="max"/>
</routes>"""


def test_trips_and_type_distributions_run_as_sumo_runs_them(tmp_path, road_net):
    """Trips (SUMO routes them) of a vTypeDistribution: two buses on the road 10 s after the
    .sumocfg's begin, each of one of the distribution's lengths."""
    path = road_scenario(tmp_path, road_net)
    (tmp_path / "buses.rou.xml").write_text(TRIPS)
    world = make_world(load_scenario(path))
    assert world.evaluate(straight(world)).traffic[0, 0, MET_START] == 2
    recording = world.recording(world.seeds(0)[0])
    lengths = np.linalg.norm(recording.corners[0, :, 0] - recording.corners[0, :, 3], axis=1)
    assert set(np.round(lengths[recording.ids[0] >= 0], 6)) <= {8.0, 14.0}


def test_learner_start_after_the_end_is_refused(tmp_path, road_net):
    path = road_scenario(tmp_path, road_net, begin=0.0, end=60.0, warmup=60.0)
    with pytest.raises(InputError, match="not before the end of road.sumocfg") as error:
        load_scenario(path)
    assert error.value.key == "traffic.warmup_s"


def test_a_life_ends_where_the_sumocfg_ends(tmp_path, road_net):
    """The .sumocfg ends 15 s after the learner's start: lives are capped at 150 steps."""
    scenario = load_scenario(road_scenario(tmp_path, road_net, end=1025.0))
    assert episode_steps(scenario) == 150
    world = make_world(scenario)
    results = world.evaluate(straight(world))
    assert results.steps[0, 0] == 150 and results.outcome[0, 0] == 0  # capped


def test_shared_warmups_are_simulated_once_and_reused(tmp_path, road_net, monkeypatch):
    """``warmup_states = 2``: over three generations of two situations, two warm-ups are
    simulated and saved; a second world reuses them and gets the same results."""
    monkeypatch.setenv(states.STATE_FOLDER_VARIABLE, str(tmp_path / "states"))
    path = road_scenario(tmp_path, road_net, warmup=30.0, extra="warmup_states = 2")
    scenario = load_scenario(path)
    population = np.random.default_rng(3).uniform(-1, 1, (6, 19 * 3 + 3 + 3 * 2 + 2))
    first = [make_world(scenario).evaluate(population, g) for g in range(3)]
    assert len(list((tmp_path / "states").glob("*.xml.gz"))) == 2
    stamps = {p: p.stat().st_mtime_ns for p in (tmp_path / "states").iterdir()}
    again = [make_world(scenario).evaluate(population, g) for g in range(3)]
    assert {p: p.stat().st_mtime_ns for p in (tmp_path / "states").iterdir()} == stamps
    for a, b in zip(first, again, strict=True):
        np.testing.assert_array_equal(a.steps, b.steps)
        np.testing.assert_array_equal(a.traffic, b.traffic)


def test_package_paths_and_unknown_packages(tmp_path):
    path = tmp_path / "scenario.toml"
    path.write_text('name = "x"\n[track]\nstart_edge = "241660955#0"\n[traffic]\n'
                    'strategy = "sumo"\nsumocfg = "pkg:no_such_package_here/a.sumocfg"\n')
    with pytest.raises(InputError, match="no installed Python package") as error:
        load_scenario(path)
    assert error.value.key == "sumocfg"


def test_city_scenario_runs_evaluates_and_meets_traffic(tmp_path, root):
    """The shipped Cologne scenario (its .sumocfg as published, begin 7:00) through the command
    line: a short run records the traffic met in generations.csv, and its best controller,
    evaluated in replay and in closed loop, starts among tens of vehicles."""
    scenario = root / "scenarios" / "city_cologne3.toml"
    out = tmp_path / "run"
    assert main(["run", str(scenario), "--out", str(out), "--quiet", "--generations", "2",
                 "--population", "20"]) == 0
    table = pd.read_csv(out / "generations.csv")
    assert (table["traffic_at_start"] > 20).all() and (table["traffic_near_max"] >= 1).all()
    rows = {}
    for mode in ("replay", "closed-loop"):
        assert main(["evaluate", str(out / "best.npz"), str(scenario), "--mode", mode,
                     "--out", str(tmp_path / f"{mode}.csv")]) == 0
        rows[mode] = pd.read_csv(tmp_path / f"{mode}.csv").iloc[0]
        assert rows[mode]["traffic_at_start"] > 20


TWO_SUMO_TRACKS = """name = "two_cities"
[traffic]
strategy = "sumo"
warmup_s = 10.0
[episode]
max_steps = 60
[[track]]
net = "{nets}/sumo_ring.net.xml"
start_edge = ["g0_0to1_0", "g1_1to0_1"]
[track.traffic]
routes = ["{routes}/ring_steady.rou.xml"]
[[track]]
net = "{nets}/sumo_grid.net.xml"
start_lane = "g0_1to1_1_1"
[track.traffic]
routes = ["{routes}/grid_crossing.rou.xml"]
"""


def test_sumo_traffic_on_several_tracks(tmp_path, root):
    """docs/scenarios.md's example: each track with its own SUMO routes, through libsumo; each
    track's lives are those of the scenario on that track alone."""
    path = tmp_path / "two.toml"
    path.write_text(TWO_SUMO_TRACKS.format(nets=root / "sumo_nets",
                                           routes=root / "scenarios" / "routes"))
    scenario = load_scenario(path)
    world = make_world(scenario)
    assert world.situation_labels() == ["sumo_ring: sumo (replay)", "sumo_grid: sumo (replay)"]
    population = np.random.default_rng(5).uniform(-1, 1, (3, world.spec.chromosome_length))
    results = world.evaluate(population, key=4)
    for index in range(2):
        alone = make_world(scenario.on_track(index)).evaluate(population, key=4)
        np.testing.assert_array_equal(results.steps[:, index], alone.steps[:, 0])
        assert alone.traffic[:, 0, 0].min() > 0  # SUMO's vehicles are there


def test_a_route_file_named_only_by_the_sumocfg_is_part_of_the_fingerprint(tmp_path, road_net):
    """A run is redone when the traffic its .sumocfg names changes, not only its settings."""
    from enn_traffic.runs.run import fingerprint

    scenario = load_scenario(road_scenario(tmp_path, road_net))
    before = fingerprint(scenario)
    routes = tmp_path / "buses.rou.xml"
    routes.write_text(routes.read_text().replace("</routes>", "<!-- one more -->\n</routes>"))
    assert fingerprint(scenario) != before


def test_training_generations_take_the_shared_warmups_in_turn(tmp_path, road_net):
    """``warmup_states = 3`` and two situations a generation: generations 0, 1, 2 load warm-ups
    0 1, 2 0, 1 2 (each twice in three generations), as generations.csv says; a held-out
    situation draws its warm-up by its own seed."""
    from enn_traffic.sim.sumo.situations import shared_warmup, situation_seed

    path = road_scenario(tmp_path, road_net, warmup=30.0, extra="warmup_states = 3")
    run = tmp_path / "run"
    assert main(["run", str(path), "--out", str(run), "--generations", "3", "--population",
                 "10", "--quiet"]) == 0
    table = pd.read_csv(run / "generations.csv", dtype={"warmups": str})
    assert list(table["warmups"]) == ["0 1", "2 0", "1 2"]
    scenario = load_scenario(path)
    counts = np.bincount([shared_warmup(scenario, g, e) for g in range(30) for e in range(2)])
    assert list(counts) == [20, 20, 20]
    held_out = 6_000_000_123
    assert shared_warmup(scenario, held_out, 1) == situation_seed(scenario, held_out, 1) % 3


def test_a_warm_up_with_actuated_lights_loads(tmp_path, monkeypatch):
    """The road's middle junction as an actuated traffic light, as OSM-built cities have them:
    SUMO 1.28 saves such a light with ``state=""`` when it has no detectors (here: green
    phases of fixed length) and then refuses to load its own state (checked below, so that
    this test keeps exercising the bug while SUMO has it). The saved
    warm-ups load, in replay and in closed loop (issue 60)."""
    import subprocess

    import libsumo
    import sumo as sumo_wheel
    from sumo_road import EDGES

    (tmp_path / "road.nod.xml").write_text(
        '<nodes><node id="w" x="0" y="0" type="priority"/>'
        '<node id="m" x="100" y="0" type="traffic_light"/>'
        '<node id="e" x="200" y="0" type="priority"/></nodes>')
    (tmp_path / "road.edg.xml").write_text(EDGES)
    subprocess.run([f"{sumo_wheel.SUMO_HOME}/bin/netconvert", "-n", "road.nod.xml", "-e",
                    "road.edg.xml", "-o", "lights.net.xml", "--no-turnarounds", "true",
                    "--tls.default-type", "actuated", "--tls.min-dur", "5", "--tls.max-dur",
                    "5"], cwd=tmp_path, check=True, capture_output=True)
    monkeypatch.setenv(states.STATE_FOLDER_VARIABLE, str(tmp_path / "states"))
    path = road_scenario(tmp_path, tmp_path / "lights.net.xml", warmup=30.0,
                         extra="warmup_states = 2")
    scenario = load_scenario(path)
    simulation = Simulation(scenario, seed=1)
    try:
        simulation.step(10)
        libsumo.simulation.saveState("raw.xml")  # into the start's folder
        assert 'state=""' in (simulation.folder / "raw.xml").read_text()
    finally:
        simulation.close()
    for mode in ("replay", "closed-loop"):
        world = make_world(scenario.with_overrides(traffic={"mode": mode}))
        results = world.evaluate(straight(world))
        assert (results.steps > 0).all()


def test_sumo_log_is_never_written_through_a_link_and_force_starts_it_over(tmp_path, road_net,
                                                                         capsys, monkeypatch):
    """Issue 64: a link at ``OUT/sumo/sumo.log`` had SUMO's log appended to its target,
    outside the output folder; ``--force`` kept the previous run's log. (The second run
    finds its generation in the cache: SUMO does not start, and the log is gone.)"""
    monkeypatch.setenv("ENN_TRAFFIC_CACHE", str(tmp_path / "cache"))
    path = road_scenario(tmp_path, road_net, extra="[ga]\npopulation_size = 4\n"
                         "elite_count = 1\ntournament_size = 2\ngenerations = 1")
    out, outside = tmp_path / "out", tmp_path / "outside.txt"
    (out / "sumo").mkdir(parents=True)
    outside.write_text("the user's own\n")
    (out / "sumo" / "sumo.log").symlink_to(outside)
    run = ["run", str(path), "--out", str(out), "--quiet"]
    assert main(run) == 2
    assert "sumo.log: cannot write SUMO's log" in capsys.readouterr().err
    assert main([*run, "--force"]) == 0
    assert outside.read_text() == "the user's own\n"
    log = out / "sumo" / "sumo.log"
    assert not log.is_symlink() and log.read_text().startswith("== SUMO, seed ")
    assert main([*run, "--force"]) == 0
    assert not log.exists()


def test_a_scenario_in_a_folder_named_with_a_comma_and_a_space_runs(tmp_path, road_net):
    """SUMO splits its file options at commas: a folder named ``a b,c`` was refused as two
    files that do not exist (issue 64)."""
    folder = tmp_path / "a b,c"
    folder.mkdir()
    path = road_scenario(folder, road_net, extra="[ga]\npopulation_size = 4\nelite_count = 1\n"
                         "tournament_size = 2\ngenerations = 1")
    assert main(["run", str(path), "--out", str(tmp_path / "out"), "--quiet"]) == 0
    assert (tmp_path / "out" / "best.npz").is_file()


def test_situations_that_start_alike_are_named_and_counted_once(tmp_path, road_net, monkeypatch):
    """One shared warm-up and one start for three held-out situations: all three start from
    the same state (``same_start_as`` 0), ``evaluate`` says so and its matrix counts the
    starting state once; with a warm-up each (none shared), three distinct."""
    from enn_traffic.runs.controller import Controller
    from enn_traffic.runs.evaluate import distinct_starts, evaluate_controller, fitness_matrix

    monkeypatch.setenv(states.STATE_FOLDER_VARIABLE, str(tmp_path / "states"))
    shared = load_scenario(road_scenario(tmp_path, road_net, warmup=30.0,
                                         extra="warmup_states = 1"))
    world = make_world(shared)
    controller = Controller.from_scenario(shared, straight(world)[0], 0.0, 0)
    table = evaluate_controller(controller, shared, episodes=3).assign(controller="c")
    assert table["same_start_as"].tolist() == [0, 0, 0]
    assert distinct_starts(table) == (1, 3)
    twice = pd.concat([table, table.assign(same_start_as=[0, 1, 2], fitness=[9.0, 9.0, 9.0],
                                           scenario="other")])
    matrix = fitness_matrix(twice)
    assert matrix.loc["c", shared.name] == pytest.approx(table["fitness"].mean())
    (tmp_path / "own").mkdir()
    own = load_scenario(road_scenario(tmp_path / "own", road_net, warmup=30.0))
    assert evaluate_controller(controller, own, episodes=3)["same_start_as"].tolist() == [0, 1, 2]
