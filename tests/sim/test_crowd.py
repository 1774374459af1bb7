"""Every vehicle driving, and learning, at once in one arena (paper §5.5)."""

import numpy as np
import pytest
from conftest import two_cars

from enn_traffic.config import GAConfig
from enn_traffic.learning.online import Evidence, OnlineLearning, VehicleGA
from enn_traffic.sim.crowd import Crowd
from enn_traffic.sim.strategies import NETWORK, STRAIGHT


@pytest.fixture
def world(tmp_path, root):
    return two_cars(tmp_path, root, (20.0, 50.0), (40.0, 50.0), 180.0)


def test_head_on_counts_one_collision_for_each_responsible_vehicle(world):
    """Two straight drivers 20 m apart, nose to nose, closing at 2 m per step: at step 11 each
    new body reaches into the other's old one, so both are responsible (two collisions); both
    respawn elsewhere and, with turning off, later hit walls."""
    starts = np.array([[20.0, 50.0, 0.0], [40.0, 50.0, np.pi]])
    arena = Crowd(world, starts, np.array([STRAIGHT, STRAIGHT]), seed=3)
    first = arena.run(1.0, np.zeros((2, world.spec.chromosome_length)))  # 10 steps: no contact
    assert first.collisions.tolist() == [0, 0]
    second = arena.run(0.1, np.zeros((2, world.spec.chromosome_length)))
    assert second.collisions.tolist() == [1, 1]
    assert second.collision_rate == pytest.approx(2 / (2 * 0.1))
    assert np.hypot(*(arena.pose[0, :2] - [31.0, 50.0])) > 1.0  # respawned


def test_learning_vehicle_moves_through_its_population(world):
    """A learner's chromosome that drives into the wall ends its life: its fitness is the
    steps it lived, and the next chromosome takes over."""
    length = world.spec.chromosome_length
    population = np.zeros((3, length))
    learner = VehicleGA(population.copy(), np.random.default_rng(0))
    starts = np.array([[80.0, 50.0, 0.0], [20.0, 20.0, np.pi / 2]])
    arena = Crowd(world, starts, np.array([NETWORK, STRAIGHT]), seed=1)
    arena.run(3.0, np.zeros((2, length)), OnlineLearning(
        [learner, None], GAConfig(population_size=3, tournament_size=2)))
    assert learner.index >= 1
    assert learner.fitness[0] == pytest.approx(20.0, abs=1.0)  # 20 m to the wall at x = 100


def test_learners_record_every_step_they_drove(world):
    """Two learners for 30 steps: whatever lives they lose, the evidence holds 2 × 30 steps,
    one loss per life ended, and the chromosomes each learner drove, in its population's order."""
    length = world.spec.chromosome_length
    rng = np.random.default_rng(5)
    learners = [VehicleGA(rng.uniform(-1, 1, (4, length)), np.random.default_rng(v))
                for v in range(2)]
    starts = np.array([[80.0, 50.0, 0.0], [20.0, 50.0, np.pi]])  # both 20 m from a wall
    arena = Crowd(world, starts, np.array([NETWORK, NETWORK]), seed=2)
    evidence = Evidence()
    run = arena.run(3.0, np.zeros((2, length)), OnlineLearning(
        learners, GAConfig(population_size=4, tournament_size=2), evidence=evidence))
    assert sum(evidence.steps.values()) == 2 * 30
    assert sum(evidence.losses.values()) == run.collisions.sum() + run.spins.sum() >= 1
    driven = {row.tobytes() for learner in learners
              for row in learner.population[: learner.index + 1]}
    assert set(evidence.chromosomes) == driven


def test_each_learner_ends_with_a_controller_of_its_own_lives(world):
    """Table 4 (§5.5.2, "a customized solution for each different vehicle"): each vehicle's
    controller is the chromosome with the fewest lives lost per step among those it drove
    itself; the pooled evidence holds both vehicles' lives."""
    length = world.spec.chromosome_length
    rng = np.random.default_rng(5)
    learners = [VehicleGA(rng.uniform(-1, 1, (4, length)), np.random.default_rng(v))
                for v in range(2)]
    starts = np.array([[80.0, 50.0, 0.0], [20.0, 50.0, np.pi]])
    arena = Crowd(world, starts, np.array([NETWORK, NETWORK]), seed=2)
    learning = OnlineLearning(learners, GAConfig(population_size=4, tournament_size=2))
    arena.run(6.0, np.zeros((2, length)), learning)  # each loses at least one life
    controllers = learning.own_controllers()
    assert controllers.shape == (2, length)
    for vehicle, learner in enumerate(learners):
        drove = {row.tobytes() for row in learner.population[: learner.index + 1]}
        own = learning.own[vehicle]
        assert set(own.chromosomes) == drove and sum(own.steps.values()) == 60
        assert sum(own.losses.values()) >= 1
        np.testing.assert_array_equal(controllers[vehicle], own.best())
    assert not np.array_equal(controllers[0], controllers[1])
    assert sum(learning.evidence.steps.values()) == 2 * 60


def test_evolved_drivers_held_to_the_spin_rule_lose_their_life_circling_on_the_spot(world):
    """A network whose only gene steers it left drives a ≈ 7 m circle: both position spreads
    stay under the spin limit, so with check_spins each vehicle spins out (and respawns)."""
    genes = np.zeros((2, world.spec.chromosome_length))
    genes[:, -1] = 1.0
    starts = np.array([[30.0, 50.0, 0.0], [70.0, 50.0, np.pi]])
    kinds = np.array([NETWORK, NETWORK])
    free = Crowd(world, starts, kinds, seed=1).run(10.0, genes.copy())
    assert free.spins.tolist() == [0, 0] and free.collisions.tolist() == [0, 0]
    held = Crowd(world, starts, kinds, seed=1).run(10.0, genes.copy(), check_spins=True)
    assert held.spins.min() >= 1 and held.collisions.tolist() == [0, 0]
    assert held.spin_rate == pytest.approx(held.spins.sum() / (2 * 10.0))


def test_a_life_at_the_cap_ends_its_chromosome_trial_without_a_respawn(world):
    """A learner driving a straight line with no wall ahead for 25 steps, cap 10: its first
    two chromosomes score the cap (no lives lost), the vehicle drives on from where it is,
    and after 2 of its 2 chromosomes it breeds its next generation."""
    length = world.spec.chromosome_length
    learner = VehicleGA(np.zeros((2, length)), np.random.default_rng(0))
    starts = np.array([[10.0, 50.0, 0.0], [20.0, 10.0, np.pi / 2]])
    arena = Crowd(world, starts, np.array([NETWORK, STRAIGHT]), seed=1)
    learning = OnlineLearning([learner, None],
                              GAConfig(population_size=2, tournament_size=2), life_cap=10)
    run = arena.run(2.5, np.zeros((2, length)), learning)
    assert run.collisions[0] == 0 and learner.lives == 0
    assert learner.generation == 1 and learner.tried == 2
    np.testing.assert_array_equal(learner.bred_from[1], [10.0, 10.0])
    assert arena.lives.life[0] == 5  # 25 steps: two trials of 10, then 5 of the third
    assert arena.pose[0, 0] == pytest.approx(10.0 + 25.0, abs=0.1)  # never moved back: 1 m a step
    assert learning.learner_rows() == [{"learner": 0, "generations_bred": 1, "lives": 0,
                                        "chromosomes_tried": 2}]


def test_respawn_at_start_puts_the_vehicle_back_on_its_own_start_pose(world):
    """The authors' respawn (reference §7.3): after its crash at the wall, 20 m ahead, the
    vehicle is back at its fixed start, heading as at first, not at a random free spot."""
    starts = np.array([[80.0, 50.0, 0.0], [20.0, 20.0, np.pi / 2]])
    kinds = np.array([STRAIGHT, STRAIGHT])
    arena = Crowd(world, starts, kinds, seed=1, respawn_at_start=True)
    run = arena.run(2.2, np.zeros((2, world.spec.chromosome_length)))
    assert run.collisions[0] == 1
    np.testing.assert_allclose(arena.pose[0], [80.0 + (22 - 20), 50.0, 0.0], atol=1.0)


@pytest.mark.parametrize("blame_all, expected", [(False, [0, 0, 2]), (True, [1, 1, 2])])
def test_the_authors_blame_after_a_respawn_tests_every_current_body(world, blame_all,
                                                                    expected):
    """Vehicles 0 and 1 nose to nose 3.5 m apart, closing 2 m per step: after step 2 their
    bodies overlap by 0.5 m, but neither reaches the other's body of before the step, so our
    rule blames neither. Vehicle 2 hits the east wall at steps 1 and 2 and respawns at its
    start each time; the authors' code then tests every car against the others' current bodies
    for a step (reference §7.3), which blames 0 and 1 at step 2."""
    starts = np.array([[20.0, 50.0, 0.0], [23.5, 50.0, np.pi], [99.5, 20.0, 0.0]])
    crowd = Crowd(world, starts, np.full(3, STRAIGHT), seed=3, respawn_at_start=True,
                  blame_all_after_respawn=blame_all)
    run = crowd.run(0.2, np.zeros((3, world.spec.chromosome_length)))
    assert run.collisions.tolist() == expected


def test_lives_lost_count_every_collision_and_spin_of_all_vehicles_per_second():
    """Two vehicles over 10 s: 1 + 2 responsible collisions and 1 spin. Ours: 3 collisions
    per 20 vehicle-seconds; lives lost: 4 per 10 s."""
    from enn_traffic.sim.crowd import CrowdRun

    run = CrowdRun(np.array([1, 2]), np.array([0, 1]), 10.0, np.zeros((101, 2, 3)))
    assert run.rate() == run.rate("responsible") == pytest.approx(0.15)
    assert run.rate("lives_lost") == pytest.approx(0.4)
