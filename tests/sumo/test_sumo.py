"""SUMO traffic through a real libsumo: the pose conversion, replay against closed loop, SUMO
drivers braking for the learner, and bad SUMO input."""

import math
import subprocess
import sys

import numpy as np
import pytest
from conftest import local_and_spread

from enn_traffic.config import load_scenario
from enn_traffic.core.errors import InputError
from enn_traffic.sim.sumo.world import SumoWorld
from enn_traffic.sim.world import COLLIDED, make_world
from enn_traffic.sumo import command, recording
from enn_traffic.sumo.learners import add_learner, move_learner
from enn_traffic.sumo.simulation import ROW_NUMBER, ROW_SLOT, Simulation, make_loadable

SCENARIO = """
name = "sumo_test"
[track]
net = "{net}"
start_lane = "{lane}"
start_offset = {offset}
[episode]
max_steps = {steps}
[traffic]
strategy = "sumo"
routes = ["routes.rou.xml"]
mode = "{mode}"
warmup_s = {warmup}
episodes = {episodes}
"""
# Clockwise laps of the ring road (its inner lanes), no driver randomness.
CLOCKWISE = """<routes>
    <vType id="car" length="4.5" width="1.8" sigma="0" speedFactor="1" maxSpeed="13"/>
    <route id="cw" edges="g1_0to0_0 g0_0to0_1 g0_1to1_1 g1_1to1_0" repeat="10"/>
    <flow id="cw" type="car" route="cw" begin="0" end="1" number="60" departPos="random_free"
          departLane="random" departSpeed="max"/>
</routes>
"""
# One fast car behind the learner's start, in its lane, that does not change lanes.
FOLLOWER = """<routes>
    <vType id="fast" length="4.5" width="1.8" sigma="0" speedFactor="1" maxSpeed="20"
           lcStrategic="-1" lcSpeedGain="0" lcKeepRight="0"/>
    <vehicle id="follower" type="fast" depart="0" departLane="0" departPos="0"
             departSpeed="20">
        <route edges="g0_0to1_0"/>
    </vehicle>
</routes>
"""

# One slow car ahead of the learner's start, in its lane (2 m/s, front 45 m along the lane).
LEADER = """<routes>
    <vType id="slow" length="4.5" width="1.8" sigma="0" speedFactor="1" maxSpeed="2"
           lcStrategic="-1" lcSpeedGain="0" lcKeepRight="0"/>
    <vehicle id="leader" type="slow" depart="0" departLane="0" departPos="45"
             departSpeed="2">
        <route edges="g0_0to1_0"/>
    </vehicle>
</routes>
"""


def sumo_scenario(tmp_path, root, routes, mode="replay", lane="g0_0to1_0_2", offset=30.0,
                  steps=300, warmup=20.0, episodes=2):
    (tmp_path / "routes.rou.xml").write_text(routes)
    path = tmp_path / "scenario.toml"
    path.write_text(SCENARIO.format(net=root / "sumo_nets" / "sumo_ring.net.xml", lane=lane,
                                    offset=offset, steps=steps, mode=mode, warmup=warmup,
                                    episodes=episodes))
    return load_scenario(path)


def test_heading_conversion_by_hand():
    """SUMO's navigation angle: 0 = north, clockwise, degrees; ours: 0 = east, anticlockwise."""
    headings = [command.to_heading(angle) for angle in (90.0, 0.0, 180.0, 45.0, 270.0)]
    assert np.allclose(headings, [0.0, math.pi / 2, -math.pi / 2, math.pi / 4, math.pi])
    assert command.to_angle(math.pi / 2) == pytest.approx(0.0)
    assert command.to_angle(-math.pi / 2) == pytest.approx(180.0)


def test_body_of_a_real_sumo_vehicle(tmp_path, root):
    """A car on the eastbound outer lane of the ring's south side (y from -15 to 0, lanes 5 m):
    its front bumper is SUMO's position, its rear 4.5 m to the west, its sides 0.9 m either
    side of the lane centre y = -12.5."""
    scenario = sumo_scenario(tmp_path, root, FOLLOWER, warmup=0.0)
    simulation = Simulation(scenario, seed=1)
    try:
        simulation.step(30)  # 60 m along: the whole body on the straight edge
        rows = simulation.read()
        import libsumo

        x, y = libsumo.vehicle.getPosition("follower")
    finally:
        simulation.close()
    assert len(rows) == 1
    ids, corners, centres = (array[0] for array in recording.slot_arrays(1, 2))
    radius = recording.fill_frame(rows, ids, corners, centres)
    slot = int(rows[0, ROW_SLOT])
    assert ids[slot] == rows[0, ROW_NUMBER] and ids[1 - slot] == -1
    assert radius == pytest.approx(0.5 * math.hypot(4.5, 1.8))
    assert y == pytest.approx(-12.5)
    front_right, front_left, rear_left, rear_right = corners[slot]
    assert front_right == pytest.approx([x, -13.4])
    assert front_left == pytest.approx([x, -11.6])
    assert rear_left == pytest.approx([x - 4.5, -11.6])
    assert rear_right == pytest.approx([x - 4.5, -13.4])
    assert centres[slot] == pytest.approx([x - 2.25, -12.5])


def test_vehicles_keep_their_slots_while_out_of_the_learners_reach(tmp_path, root):
    """In closed loop only the vehicles near the learner are read (a context subscription).
    Clockwise cars lap the ring past a learner parked beside their lanes: each comes back into
    reach, with the slot and number it had, so one that left the learner's world stays out of
    it. SUMO's built-in 135 m train type does not count as traffic."""
    scenario = sumo_scenario(tmp_path, root, CLOCKWISE, warmup=0.0)
    simulation = Simulation(scenario, seed=1)
    slot_of, entries, present = {}, {}, set()
    try:
        simulation.step(10)
        assert simulation.largest_radius() == pytest.approx(0.5 * math.hypot(5.0, 1.8))
        add_learner(4.3, 2.5, 0.0)
        simulation.follow_learner(15.0)
        for _ in range(900):  # a lap takes about 50 s
            move_learner(80.0, -2.5, 0.0)
            simulation.step()
            rows = simulation.read()
            slots, numbers = rows[:, ROW_SLOT], rows[:, ROW_NUMBER]
            for slot, number in zip(slots.tolist(), numbers.tolist(), strict=True):
                assert slot_of.setdefault(number, slot) == slot
                entries[number] = entries.get(number, 0) + (number not in present)
            present = set(numbers.tolist())
    finally:
        simulation.close()
    assert 10 <= len(slot_of) <= 60  # numbers: at most one per car of the flow
    assert sum(count >= 2 for count in entries.values()) >= 10  # cars that came back


def test_replay_and_closed_loop_agree_where_traffic_does_not_react(tmp_path, root):
    """Clockwise traffic on the inner lanes; the learner starts next to it in an anticlockwise
    lane. While the learner stays on its own side of the road (y < 0 on the south side), no
    SUMO driver has it ahead, and it lives exactly as long in both modes; the traffic it sees
    changes some of those lifetimes."""
    rng = np.random.default_rng(5)
    replay = make_world(sumo_scenario(tmp_path, root, CLOCKWISE))
    population = rng.uniform(-1, 1, (40, replay.spec.chromosome_length))
    replayed = replay.evaluate(population, key=3)
    closed = make_world(sumo_scenario(tmp_path, root, CLOCKWISE, mode="closed-loop"))
    live = closed.evaluate(population, key=3)
    no_traffic = {"strategy": "random_network", "routes": []}  # the same road, no vehicle
    alone = make_world(replay.scenario.with_overrides(traffic=no_traffic)).evaluate(population,
                                                                                    3)
    own_side = np.array([[np.nanmax(replay.trace(chromosome, 3, episode)[0][:, 0, 1]) < -1.0
                          for episode in range(2)] for chromosome in population])
    assert own_side.sum() >= 20
    assert np.array_equal(replayed.steps[own_side], live.steps[own_side])
    assert np.array_equal(replayed.outcome[own_side], live.outcome[own_side])
    assert (alone.steps[own_side] != replayed.steps[own_side]).any()


def test_replay_records_sumo_only_as_far_as_the_lives_reach(tmp_path, root, monkeypatch):
    """A replay records 16 steps first (here), then 4 times more while a life outlives the
    recording: every life, trace and environment step is what a recording of the whole cap
    (2,000 steps) gives, and SUMO ran only as far as the longest life."""
    from enn_traffic.sim.sumo import world as sumo_world

    scenario = sumo_scenario(tmp_path, root, CLOCKWISE, steps=2000)
    sumo_world.forget_recordings()  # those of other tests in this process
    monkeypatch.setattr(sumo_world, "FIRST_RECORDING", 10**6)
    whole = make_world(scenario)
    population = np.random.default_rng(5).uniform(-1, 1, (30, whole.spec.chromosome_length))
    expected = whole.evaluate(population, key=3)
    assert {r.ids.shape[0] for r in sumo_world._recordings.values()} == {2001}
    sumo_world.forget_recordings()
    monkeypatch.setattr(sumo_world, "FIRST_RECORDING", 16)
    world = make_world(scenario)
    results = world.evaluate(population, key=3)
    for column in ("steps", "outcome", "suffered", "hit"):
        np.testing.assert_array_equal(getattr(results, column), getattr(expected, column))
    longest = results.steps.max(axis=0)
    assert 16 < longest.max() < 2000
    recorded = [sumo_world._recordings[world._traffic, seed, None].ids.shape[0] - 1
                for seed in world.seeds(3)]
    assert all(longest[e] <= recorded[e] < max(16, 4 * longest[e]) + 1 for e in range(2))
    best = int(np.argmax(results.steps[:, 0]))
    poses, outcome = make_world(scenario).trace(population[best], key=3)
    assert len(poses) - 1 == results.steps[best, 0] and outcome == results.outcome[best, 0]


def test_a_replayed_trace_ends_with_its_recording(tmp_path, root):
    """A replay records ``max_steps`` (50) steps; a trace asked for 400 ends there, as long as
    the life it shows (all genes 0: straight ahead, round the ring's corner into a wall or
    on to the cap), and agrees with evaluate."""
    world = make_world(sumo_scenario(tmp_path, root, CLOCKWISE, steps=50))
    straight = np.zeros((1, world.spec.chromosome_length))
    poses, outcome = world.trace(straight, key=3, max_steps=400)
    results = world.evaluate(straight, key=3)
    assert poses.shape[0] == int(results.steps[0, 0]) + 1 <= 51
    assert outcome == int(results.outcome[0, 0])


def test_closed_loop_driver_brakes_for_the_learner(tmp_path, root):
    """A 20 m/s car starts 30 m behind the learner (10 m/s, steering straight). Replayed, it
    drives into the learner (a collision the learner suffers); in closed loop it brakes and
    stays behind."""
    straight = np.zeros(SumoWorld(sumo_scenario(tmp_path, root, FOLLOWER)).spec.chromosome_length)
    results = {}
    for mode in ("replay", "closed-loop"):
        scenario = sumo_scenario(tmp_path, root, FOLLOWER, mode=mode, lane="g0_0to1_0_0",
                                 offset=30.0, steps=90, warmup=0.0, episodes=1)
        world = make_world(scenario)
        results[mode] = world.evaluate(straight[None, :])
        poses, _ = world.trace(straight)
        results[mode + " poses"] = poses
    assert results["replay"].suffered[0, 0] == 1
    assert results["closed-loop"].suffered[0, 0] == 0
    poses = results["closed-loop poses"]
    learner_rear = poses[-1, 0, 0] - 4.3
    follower_front = np.nanmax(poses[-1, 1:, 0])
    assert follower_front < learner_rear
    follower_speed = (np.nanmax(poses[-1, 1:, 0]) - np.nanmax(poses[-11, 1:, 0])) / 1.0
    assert follower_speed == pytest.approx(10.0, abs=1.5)


@pytest.mark.parametrize("routes, needle", [
    # a cut file: refused as XML when the scenario is read, before SUMO starts
    ("<routes><vehicle id='a' depart='0'", "not readable XML: unclosed token"),
    ("<routes><vehicle id='a' type='no_such_type' depart='0'><route edges='g0_0to1_0'/>"
     "</vehicle></routes>", "no_such_type"),
    ("<routes><vehicle id='a' depart='0'><route edges='no_such_edge'/></vehicle></routes>",
     "no_such_edge"),
])
def test_bad_sumo_input_is_one_clear_message(tmp_path, root, routes, needle):
    with pytest.raises(InputError, match=needle) as error:
        world = make_world(sumo_scenario(tmp_path, root, routes))
        world.evaluate(np.zeros((1, world.spec.chromosome_length)))
    assert error.value.key == "traffic.routes"
    result = subprocess.run(
        [sys.executable, "-m", "enn_traffic", "run", str(tmp_path / "scenario.toml"),
         "--generations", "1", "--population", "10", "--out", str(tmp_path / "out")],
        capture_output=True, text=True)
    assert result.returncode == 2
    assert "traffic.routes" in result.stderr and "Traceback" not in result.stderr


def test_missing_route_file_names_the_key(tmp_path, root):
    scenario_path = tmp_path / "s.toml"
    scenario_path.write_text(SCENARIO.format(
        net=root / "sumo_nets" / "sumo_ring.net.xml", lane="g0_0to1_0_1", offset=10, steps=10,
        mode="replay", warmup=0, episodes=1))
    with pytest.raises(InputError, match="route file not found") as error:
        load_scenario(scenario_path)
    assert error.value.key == "traffic.routes[0]"


def test_process_pool_with_one_libsumo_per_worker_gives_the_local_results(tmp_path, root):
    """Each worker process runs its own libsumo and records the same traffic."""
    from enn_traffic.learning.evaluators import ProcessEvaluator

    scenario = sumo_scenario(tmp_path, root, CLOCKWISE, steps=150, episodes=1)
    population = np.random.default_rng(2).uniform(-1, 1, (9, 68))
    local, spread = local_and_spread(scenario, population, 4, ProcessEvaluator(scenario, 2))
    np.testing.assert_array_equal(local.steps, spread.steps)
    np.testing.assert_array_equal(local.outcome, spread.outcome)


def test_closed_loop_records_the_learners_conflicts_with_ssm(tmp_path, root):
    """SUMO's SSM device on the learner. The 20 m/s car departs at the lane's start (x = 15 m)
    behind the learner, which starts 15 m along the lane and enters SUMO after its first step
    (10 m/s, front at x = 31 m, rear at 26.7 m): time-to-collision 11.7 m / 10 m/s = 1.17 s,
    below 1.5 s; the deceleration that avoids a crash, 10² / (2 · 11.7) = 4.3 m/s², above 3.
    One conflict, by TTC and by DRAC. The two-dimensional time to collision over the
    footprints sees the same encounter within a step's closing (0.1 s): it reads the car's
    speed from its travel since the step before. A replay has no learner in SUMO: no
    figures."""
    length = SumoWorld(sumo_scenario(tmp_path, root, FOLLOWER)).spec.chromosome_length
    straight = np.zeros((1, length))
    settings = dict(lane="g0_0to1_0_0", offset=15.0, steps=90, warmup=0.0, episodes=1)
    closed = make_world(sumo_scenario(tmp_path, root, FOLLOWER, mode="closed-loop", **settings))
    safety = closed.evaluate(straight).safety[0, 0]
    min_ttc, ttc, drac, pet, min_ttc_2d, _ = safety
    assert min_ttc == pytest.approx(1.17, abs=0.01)
    assert (ttc, drac, pet) == (1, 1, 0)
    assert min_ttc_2d == pytest.approx(min_ttc, abs=0.1)
    replay = make_world(sumo_scenario(tmp_path, root, FOLLOWER, **settings))
    assert replay.evaluate(straight).safety is None


def test_ssm_sees_the_learner_closing_on_a_vehicle_ahead(tmp_path, root):
    """The learner (10 m/s) drives straight at a 2 m/s car ahead in its lane: 25.5 m from the
    car's rear at its start, it closes at 8 m/s and runs into it after about 3.2 s. On the way
    the time-to-collision, gap / 8 m/s, falls through 1.5 s towards 0: SUMO's SSM device on
    the learner records the conflict with a finite, small TTC (the device once saw nothing
    of a learner that SUMO itself drove: issue 60). The two-dimensional time to collision
    reaches 0 as the bodies touch, and is below 1.5 s from 12 m (8 m/s · 1.5 s) on: 12 m at
    0.8 m a step is 15 steps, and the step of the contact."""
    length = SumoWorld(sumo_scenario(tmp_path, root, LEADER)).spec.chromosome_length
    straight = np.zeros((1, length))
    scenario = sumo_scenario(tmp_path, root, LEADER, mode="closed-loop", lane="g0_0to1_0_0",
                             offset=15.0, steps=60, warmup=0.0, episodes=1)
    results = make_world(scenario).evaluate(straight)
    min_ttc, ttc, drac, _, min_ttc_2d, below = results.safety[0, 0]
    assert results.outcome[0, 0] == COLLIDED and results.hit[0, 0] >= 0  # the car, not a wall
    assert min_ttc < 0.5
    assert ttc == 1 and drac == 1
    assert (min_ttc_2d, below) == (0.0, 16)


@pytest.mark.parametrize("mode", ["replay", "closed-loop"])
def test_a_traced_collision_ends_with_the_learners_body_on_what_it_hit(tmp_path, root, mode):
    """The learner drives into the slow car ahead: the trace's last pose is where its last
    move took it, and its body there touches the body the car had before that move (what
    the blame rule tested, what ``render`` draws up close); a step earlier it did not."""
    from enn_traffic.core.geometry import body_corners
    from enn_traffic.sim.rules import boxes_overlap

    length = SumoWorld(sumo_scenario(tmp_path, root, LEADER)).spec.chromosome_length
    scenario = sumo_scenario(tmp_path, root, LEADER, mode=mode, lane="g0_0to1_0_0",
                             offset=15.0, steps=60, warmup=0.0, episodes=1)
    life = make_world(scenario).trace_life(np.zeros(length))
    assert life.outcome == COLLIDED and life.hit_vehicle[0] == "leader"

    def body(row: int) -> np.ndarray:
        corners = np.empty((4, 2))
        body_corners(*life.poses[row, 0], scenario.vehicle.length, scenario.vehicle.width,
                     corners)
        return corners

    assert boxes_overlap(body(-1), life.hit_body)
    assert not boxes_overlap(body(-2), life.hit_body)


def test_the_learners_speed_factor_lets_them_go_their_speed_on_the_slowest_lane(root,
                                                                              tmp_path):
    """The ring's slowest car lanes are its right turns inside the junctions (4.88 m/s in its
    .net.xml): a 10 m/s learner's type gets the factor 10 / 4.88, enters at 10 m/s, and a 3 m/s
    one gets SUMO's usual 1 (in a fresh process: libsumo keeps state between starts). A
    learner added to a start not told where SSM writes carries no SSM device, so nothing is
    written into the working folder (SUMO's ``ssm_<id>.xml``)."""
    script = f"""
import libsumo
from enn_traffic.sumo.command import LEARNER, LEARNER_TYPE
from enn_traffic.sumo.learners import add_learner, learner_speed_factor
libsumo.start(["sumo", "-n", {str(root / "sumo_nets" / "sumo_ring.net.xml")!r},
               "--no-step-log", "true"])
print(learner_speed_factor(10.0), learner_speed_factor(3.0))
add_learner(4.3, 1.7, 10.0)
libsumo.simulationStep()
print(libsumo.vehicletype.getSpeedFactor(LEARNER_TYPE), libsumo.vehicle.getSpeed(LEARNER))
libsumo.close()
"""
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True,
                          cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    assert list(tmp_path.iterdir()) == []
    factors, inserted = (list(map(float, line.split())) for line in done.stdout.split("\n")[:2])
    assert factors == pytest.approx([10.0 / 4.88, 1.0])
    assert inserted == pytest.approx([10.0 / 4.88, 10.0])


def test_a_saved_state_is_made_loadable(tmp_path):
    """What SUMO 1.28 saves but cannot load again (issue 60): an actuated light's empty
    ``state`` is left out, and so are rail signals' drive ways (they crash libsumo at the
    third start in a process, seen on an OSM-built city with trams); the rest stays as
    saved, byte for byte."""
    import gzip

    kept = ('<snapshot time="300.00" version="1.28.0">\n'
            '    <tlLogic id="a" programID="0" phase="5" active="1"{}/>\n'
            '    <tlLogic id="b" programID="0" phase="1" active="1" state="4.00 5.00"/>\n')
    saved = (kept.format(' state=""')
             + '    <driveWay id="s.d0" edges="e1 e2" vehicles="tram:0.0"/>\n'
             + '    <subDriveWay id="s.d0.0" edges="e1" vehicles="tram:0.0"/>\n</snapshot>\n')
    path = tmp_path / "state.xml.gz"
    with gzip.open(path, "wt") as file:
        file.write(saved)
    make_loadable(path)
    with gzip.open(path, "rt") as file:
        assert file.read() == kept.format("") + "</snapshot>\n"


def test_sumo_outputs_of_every_vehicle_without_a_sumocfg(tmp_path, root):
    """``traffic.outputs``: SUMO's tripinfo, FCD and SSM outputs of every vehicle, kept per
    SUMO start in the run's ``sumo/outputs/``. The closed loop of the leader test: the slow
    car's trip (unfinished when the life ends) and positions are there, and SSM's file, where
    every vehicle's device writes, holds the learner's conflict, which its own figures count
    as they do without the outputs."""
    import xml.etree.ElementTree as ElementTree

    scenario = sumo_scenario(tmp_path, root, LEADER, mode="closed-loop", lane="g0_0to1_0_0",
                             offset=15.0, steps=60, warmup=0.0, episodes=1)
    alone = make_world(scenario)
    straight = np.zeros((1, alone.spec.chromosome_length))
    own = alone.evaluate(straight).safety
    scenario = scenario.with_overrides(traffic={"outputs": ["tripinfo", "fcd", "ssm"]}
                                       ).with_sumo_output(tmp_path / "sumo")
    results = make_world(scenario).evaluate(straight)
    np.testing.assert_array_equal(results.safety, own)
    starts = list((tmp_path / "sumo" / "outputs").iterdir())  # the check for traffic, the life
    vehicles = {start: {v.get("id") for v in ElementTree.parse(start / "fcd.xml").iter("vehicle")}
                for start in starts}
    [start] = [start for start in starts if command.LEARNER in vehicles[start]]
    assert "leader" in vehicles[start]
    assert {p.name for p in start.iterdir()} == {"tripinfo.xml", "fcd.xml", "ssm.xml"}
    assert ElementTree.parse(start / "tripinfo.xml").getroot().find("tripinfo") is not None
    conflicts = ElementTree.parse(start / "ssm.xml").getroot().findall("conflict")
    assert {c.get("ego") for c in conflicts} <= {command.LEARNER, "leader"}
    assert len([c for c in conflicts if c.get("ego") == command.LEARNER]) == own[0, 0, 1] == 1


def test_a_collision_on_a_city_scale_is_drawn_up_close(tmp_path):
    """A 600 m path ending on a 4.5 m car: on the map the car is a few pixels under the end
    marker; the inset draws it 24 m across, hundreds of pixels of its colour."""
    from PIL import Image

    from enn_traffic.report.plots import learner_among_traffic

    x = np.linspace(0.0, 600.0, 601)
    poses = np.stack([x, np.zeros_like(x), np.zeros_like(x)], axis=1)[:, None, :]
    car = np.array([[602.0, -0.9], [602.0, 0.9], [597.5, 0.9], [597.5, -0.9]])
    body = np.array([[600.0, -0.85], [600.0, 0.85], [595.7, 0.85], [595.7, -0.85]])
    out = tmp_path / "hit.png"
    learner_among_traffic(np.zeros((0, 4)), np.zeros((0, 4)), poses, out, "a city", "end",
                          hit_body=car, learner_body=body)
    pixels = np.asarray(Image.open(out).convert("RGB")).astype(int)
    orange = (np.abs(pixels - [255, 145, 50]) < 40).all(axis=2).sum()  # C1, nearly opaque
    assert orange > 400
