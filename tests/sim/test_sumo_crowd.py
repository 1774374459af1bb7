"""Several learners at once in a live SUMO (paper §5.5 among SUMO traffic), through the real
libsumo, on the ring road's south side: y from -15 (outer wall) to 15 (inner wall) between
x = 15 and 145, learners 1 m a step (10 m/s, 0.1 s)."""

import numpy as np
import pytest

from enn_traffic.config import GAConfig, load_scenario
from enn_traffic.config.shipped import shipped_scenario
from enn_traffic.core import keys
from enn_traffic.learning.online import OnlineLearning, VehicleGA
from enn_traffic.sim.sumo.crowd import SumoCrowd
from enn_traffic.sim.world import make_world

SCENARIO = """
name = "sumo_crowd_test"
[track]
net = "{net}"
start_lane = "g0_0to1_0_2"
[traffic]
strategy = "sumo"
routes = ["routes.rou.xml"]
mode = "closed-loop"
warmup_s = 0.0
learners = 2
"""
# One car that departs long after every test ends: SUMO's traffic stays out of the way.
LATE_CAR = """<routes>
    <vType id="car" length="4.5" width="1.8" sigma="0"/>
    <vehicle id="late" type="car" depart="1000"><route edges="g0_0to1_0"/></vehicle>
</routes>
"""


@pytest.fixture
def world(tmp_path, root):
    (tmp_path / "routes.rou.xml").write_text(LATE_CAR)
    path = tmp_path / "scenario.toml"
    path.write_text(SCENARIO.format(net=root / "sumo_nets" / "sumo_ring.net.xml"))
    return make_world(load_scenario(path))


def straight(world) -> np.ndarray:
    """Zero genes: both outputs 0.5, no steering."""
    return np.zeros((2, world.spec.chromosome_length))


def test_head_on_learners_are_both_responsible_at_the_hand_computed_step(world):
    """Nose to nose 20 m apart, closing at 2 m a step: at step 11 each new body reaches into
    the other's body from before the step (60 + 11 = 81 > 80 - 10), never at step 10."""
    starts = np.array([[60.0, 5.0, 0.0], [80.0, 5.0, np.pi]])
    with SumoCrowd(world, seed=1, starts=starts) as crowd:
        assert crowd.run(1.0, straight(world)).collisions.tolist() == [0, 0]
        run = crowd.run(0.1, straight(world))  # step 11
    assert run.collisions.tolist() == [1, 1]
    assert run.collision_rate == pytest.approx(2 / (2 * 0.1))


def test_learners_closing_head_on_count_one_2d_conflict_each_and_side_by_side_none(world):
    """Nose to nose less than 20 m apart, closing at 20 m/s: their 2-D time to collision is
    below 1.5 s from the first step, one conflict each that lasts until they collide (none
    more at the collision's step). Side by side, 5 m apart at the same speed and heading:
    never closing, no conflict."""
    starts = np.array([[60.0, 5.0, 0.0], [80.0, 5.0, np.pi]])
    with SumoCrowd(world, seed=1, starts=starts) as crowd:
        assert crowd.run(1.0, straight(world)).conflicts_2d == 2
        assert crowd.run(0.1, straight(world)).conflicts_2d == 0
        assert crowd.lives.learners.conflicts.tolist() == [1, 1]
    side_by_side = np.array([[60.0, 5.0, 0.0], [60.0, 0.0, 0.0]])
    with SumoCrowd(world, seed=1, starts=side_by_side) as crowd:
        run = crowd.run(1.0, straight(world))
    assert run.conflicts_2d == 0 and run.collisions.tolist() == [0, 0]


def test_a_learner_that_hits_a_wall_re_enters_at_a_free_spot(world):
    """Heading south from y = 5.5, the front reaches the outer wall (y = -15) at step 21
    (5.5 - 21 = -15.5); the learner then drives on from a free spot on the road, at least the
    respawn clearance from the other learner."""
    starts = np.array([[80.0, 5.5, -np.pi / 2], [30.0, 5.0, 0.0]])
    with SumoCrowd(world, seed=1, starts=starts) as crowd:
        assert crowd.run(2.0, straight(world)).collisions.tolist() == [0, 0]
    with SumoCrowd(world, seed=1, starts=starts) as crowd:
        run = crowd.run(2.5, straight(world))
    assert run.collisions.tolist() == [1, 0]
    assert run.trace[21, 0, 1] == pytest.approx(-15.5)
    again = run.trace[22, 0]
    assert np.hypot(again[0] - 80.0, again[1] + 16.5) > 5.0
    assert world.track.contains(again[0], again[1])
    clearance = world.scenario.traffic.respawn_clearance
    assert np.hypot(*(again[:2] - run.trace[22, 1, :2])) >= clearance - 2.0  # one step each


def test_learners_move_through_their_populations(world):
    """Each learner's own GA: the first chromosome's life ends at the wall (the hand-computed
    21 steps for the learner heading south), its fitness recorded, the next one takes over."""
    length = world.spec.chromosome_length
    learners = [VehicleGA(np.zeros((3, length)), np.random.default_rng(k)) for k in range(2)]
    learning = OnlineLearning(learners, GAConfig(population_size=3, tournament_size=2))
    starts = np.array([[80.0, 5.5, -np.pi / 2], [30.0, 5.0, 0.0]])
    with SumoCrowd(world, seed=1, starts=starts) as crowd:
        run = crowd.run(2.5, straight(world), learning)
    assert run.collisions[0] == 1
    assert learners[0].index == 1
    assert learners[0].fitness[0] == pytest.approx(21.0)
    assert learners[1].index == 0  # still on its first life


def test_one_situation_of_the_sumo_tables_is_the_same_run_again(world):
    """Every arm of a situation (initial drivers, winner, learning, after learning) from the
    situation's seed alone: the same call gives the same rates, windows, learners and
    controllers; the random initial drivers lose lives in the first window and the window
    after learning, and so do the learners; learners with a 10-step cap and 4 chromosomes
    breed within 6 s."""
    from enn_traffic.experiments.crowds.settings import CrowdSettings
    from enn_traffic.experiments.crowds.sumo import CONFLICTS, situation_result

    winner = straight(world)[0]
    evolved = np.random.default_rng(0).uniform(-1, 1, (6, world.spec.chromosome_length))
    learning = CrowdSettings(learning_s=6.0, window_s=3.0, life_cap_steps=10,
                             population_size=4, elite_count=1, situations=1)
    first = situation_result(world, winner, evolved, 0, learning)
    assert set(first.rates) == {"initial", "winner", "initial_after", "winner_after",
                                "population", "learning"} | {
        f"{arm}_{measure}" for arm in CONFLICTS for measure in ("conflicts", "conflicts_2d")}
    again = situation_result(world, winner, evolved, 0, learning)
    assert (first.rates, first.windows, first.learners) == (again.rates, again.windows,
                                                           again.learners)
    np.testing.assert_array_equal(first.controllers, again.controllers)
    assert first.rates["initial"] > 0 and first.rates["initial_after"] > 0
    assert first.rates["learning"] > 0
    assert [w["window_start_s"] for w in first.windows] == [0.0, 3.0]
    assert all(learner["generations_bred"] >= 1 for learner in first.learners)
    assert first.controllers.shape == (world.scenario.traffic.learners, len(winner))
    # breeding makes children: 3 of each generation's 4 beside the 1 elite, even where the
    # scenario's own GA keeps 4 elites
    from enn_traffic.experiments.crowds.sumo import learn_together

    four_elites = make_world(world.scenario.with_overrides(ga={"elite_count": 4}))
    *_, online = learn_together(four_elites, winner, evolved, 0, learning)
    started = {row.tobytes() for row in evolved[:4]}
    for learner in online.learners:
        assert sum(row.tobytes() not in started for row in learner.population) >= 3


def test_a_sumo_vehicle_that_drives_into_a_learner_leaves_that_learners_world_only(world):
    """Learner 0 moved 1 m east to a front at x = 80; a SUMO car behind it moved from a front
    0.5 m behind the learner's old rear to 1 m into the learner's old body: the car is
    responsible (the learner suffers one collision, lives on) and leaves learner 0's world,
    not learner 1's."""
    from enn_traffic.core.geometry import body_corners
    from enn_traffic.sim.rules import Vehicles
    from enn_traffic.sim.sumo.crowd_rules import ALIVE, learner_events, learners_for
    from enn_traffic.sumo import recording

    length, width = world.scenario.vehicle.length, world.scenario.vehicle.width

    def body(front_x, car_length=length):
        corners = np.empty((4, 2))
        body_corners(front_x, 5.0, 0.0, car_length, width, corners)
        return corners, corners[[0, 2]].mean(axis=0)

    pose = np.array([[80.0, 5.0, 0.0], [30.0, 5.0, 0.0]])
    now_bodies = [body(80.0), body(30.0)]
    before_bodies = [body(79.0), body(29.0)]
    ids, corners, centres = recording.slot_arrays(2, 4)
    old_rear = 79.0 - length
    for row, front in ((0, old_rear - 0.5), (1, old_rear + 1.0)):  # before, now
        ids[row, 0] = 7
        corners[row, 0], centres[row, 0] = body(front, 4.5)
    vehicles = Vehicles(pose, np.array([b[0] for b in now_bodies]),
                        np.array([b[1] for b in now_bodies]),
                        np.array([b[0] for b in before_bodies]),
                        np.array([b[1] for b in before_bodies]), np.zeros(2, dtype=np.bool_),
                        np.zeros((2, 2)))
    physics = world._learner_physics(2.5)
    learners = learners_for(2, physics.spin_window, 4)
    learners.life[:], learners.spin_checked[:] = 5, False
    ended = learner_events(5, vehicles, learners, physics, world.geometry,
                           (ids, corners, centres), 0, 1)
    events, suffered, gone = learners.events, learners.suffered, learners.gone
    assert not ended and events.tolist() == [ALIVE, ALIVE]
    assert suffered.tolist() == [1, 0]
    assert gone[:, 0].tolist() == [7, -1]


def test_runs_one_after_another_are_one_run_cut_in_pieces():
    """A crowd driven 20 s in 40 runs of 0.5 s goes where one 20 s run goes and counts the
    same collisions: the step where one run ends and the next begins is judged once (it was
    judged twice, counting again what SUMO's vehicles had done there)."""
    world = make_world(shipped_scenario("sumo_strategy3"))
    rng = np.random.default_rng(5)
    genes = world.spec.in_source_layout(
        rng.uniform(-1, 1, (world.scenario.traffic.learners, world.spec.chromosome_length)))
    seed = world.seeds(keys.VALIDATION.start)[0]
    with SumoCrowd(world, seed) as crowd:
        whole = crowd.run(20.0, genes)
    with SumoCrowd(world, seed) as crowd:
        pieces = [crowd.run(0.5, genes) for _ in range(40)]
    trace = np.concatenate([pieces[0].trace] + [piece.trace[1:] for piece in pieces[1:]])
    np.testing.assert_array_equal(trace, whole.trace)
    for counted in ("collisions", "spins", "exits", "suffered"):
        assert sum(getattr(piece, counted) for piece in pieces).tolist() == getattr(
            whole, counted).tolist(), counted
    assert whole.collisions.sum() > 0 and whole.suffered.sum() > 0  # there was something to count


def test_a_learner_at_the_cap_drives_on_with_its_next_chromosome(world):
    """Two learners driving east side by side, nothing ahead for 25 steps, cap 10: each tries
    both of its 2 chromosomes to the cap without losing a life, breeds, and drives on from where
    it is (no re-entry)."""
    starts = np.array([[20.0, 5.0, 0.0], [20.0, -5.0, 0.0]])
    length = world.spec.chromosome_length
    learners = [VehicleGA(np.zeros((2, length)), np.random.default_rng(k)) for k in range(2)]
    learning = OnlineLearning(learners, GAConfig(population_size=2, tournament_size=2),
                              life_cap=10)
    with SumoCrowd(world, seed=1, starts=starts) as crowd:
        run = crowd.run(2.5, straight(world), learning)
        pose = crowd.lives.pose.copy()
    assert run.collisions.tolist() == [0, 0]
    assert [(g.generation, g.tried, g.lives) for g in learners] == [(1, 2, 0), (1, 2, 0)]
    np.testing.assert_allclose(pose[:, 0], [45.0, 45.0], atol=0.1)


@pytest.mark.full
def test_a_crowds_conflicts_are_the_same_whatever_ran_before_in_the_process():
    """The stop-and-go crowd (the SUMO family's strategy 3), 8 random drivers over two 50 s
    spans, each SUMO start in a fresh process: the same SSM conflicts and collisions before
    and after a city closed-loop life ran SUMO in this process; and in this process itself,
    where SUMO's list of the one learner it equipped once stayed for every later start and
    the crowd counted only its first learner's conflicts (docs/sumo.md, "One SUMO start, one
    process")."""
    from enn_traffic.experiments.crowds.sumo import _driving_arm, crowd_world
    from enn_traffic.experiments.families import CITY, SUMO
    from enn_traffic.sumo.fresh import fresh

    world = crowd_world(SUMO, 3)
    genes = np.random.default_rng(0).uniform(-1, 1, (world.scenario.traffic.learners,
                                                     world.spec.chromosome_length))
    spans = (world.scenario, world.seeds(keys.CROWD_TEST.start)[0], genes, 50.0, 2)

    def counted(runs):
        return [(run.ttc_conflicts, run.collisions.tolist()) for run in runs]

    before = counted(fresh(_driving_arm, *spans)[0])
    city = make_world(CITY.scenario(1).with_overrides(
        traffic={"mode": "closed-loop"}, episode={"max_steps": 200}))
    city.closed_loop(np.zeros(city.spec.chromosome_length), city.seeds(5)[0])
    assert counted(fresh(_driving_arm, *spans)[0]) == before
    assert counted(_driving_arm(*spans)[0]) == before


@pytest.mark.parametrize("devices", [True, False])
def test_learners_carry_ssm_devices_unless_told_not_to(world, devices):
    """The crowd's tables count every learner's SSM conflicts, after a one-learner SUMO ran in
    the same process too (SUMO keeps the first start's --device.ssm.explicit list of ids for
    the process's life: it equipped only the first learner); a crowd made without the
    devices (bench crowd_marginal's arm of what they cost) equips no learner."""
    import libsumo

    alone = make_world(world.scenario.with_overrides(traffic={"learners": 1}))
    alone.closed_loop(np.zeros(alone.spec.chromosome_length), alone.seeds(5)[0])
    starts = np.array([[60.0, 5.0, 0.0], [30.0, 5.0, 0.0]])
    with SumoCrowd(world, seed=1, starts=starts, ssm_devices=devices) as crowd:
        crowd.run(0.2, straight(world))
        equipped = [libsumo.vehicle.getParameter(v, "has.ssm.device") for v in crowd.ids]
    assert equipped == ["true" if devices else "false"] * 2


def test_the_spots_remembered_free_of_walls_are_those_the_walls_leave_free():
    """Re-entries remember per lane spot whether a body there touches a wall (a pass over every
    wall each time otherwise): after lives on the Cologne junctions that end and re-enter,
    every spot remembered says what testing it again says, and both answers occur."""
    from enn_traffic.experiments.families import CITY
    from enn_traffic.sim.rules import clear_of_walls_at

    world = make_world(CITY.scenario(1).with_overrides(
        traffic={"mode": "closed-loop", "learners": 8}))
    genes = np.random.default_rng(3).uniform(-1, 1, (8, world.spec.chromosome_length))
    with SumoCrowd(world, seed=1) as crowd:
        run = crowd.run(20.0, genes)
        known = crowd.lives.clear_of_walls
        spots, physics = world.lane_spots, crowd.physics
    assert run.collisions.sum() + run.exits.sum() > 0
    trial = np.empty((4, 2))
    remembered = np.flatnonzero(known >= 0)
    assert [bool(known[s]) for s in remembered] == [
        clear_of_walls_at(*spots[s], physics, world.geometry, trial) for s in remembered]
    assert set(known[remembered].tolist()) == {0, 1}


def test_a_crowd_whose_learners_find_no_room_ends_its_sumo(world):
    """A start that fails once SUMO runs (here: more learners than the ring's lanes take)
    ends that SUMO, so that the process can start the next one."""
    import libsumo

    from enn_traffic.core.errors import InputError
    from enn_traffic.sumo.simulation import Simulation

    packed = make_world(world.scenario.with_overrides(traffic={"learners": 400}))
    with pytest.raises(InputError, match="no free spot for a learner"):
        SumoCrowd(packed, seed=1).start()
    assert Simulation.running is None and not libsumo.simulation.isLoaded()
    with SumoCrowd(world, seed=1) as crowd:
        assert crowd.run(0.5, straight(world)).collisions.tolist() == [0, 0]
