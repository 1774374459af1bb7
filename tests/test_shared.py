"""Every vehicle driving and learning at once in one arena (paper §5.5)."""

import numpy as np
import pytest
from conftest import two_cars

from enn_traffic.evolution import ga
from enn_traffic.evolution.online import Evidence, OnlineLearning, VehicleGA, global_elites
from enn_traffic.sim.crowd import Crowd
from enn_traffic.traffic.strategies import NETWORK, STRAIGHT


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
        [learner, None], ga.GAParams(population_size=3, tournament_size=2)))
    assert learner.index >= 1
    assert learner.fitness[0] == pytest.approx(20.0, abs=1.0)  # 20 m to the wall at x = 100


def test_exhausted_population_breeds_with_theglobal_elites(world):
    rng = np.random.default_rng(4)
    length = world.spec.chromosome_length
    learners = [VehicleGA(rng.uniform(-1, 1, (6, length)), np.random.default_rng(v))
                for v in range(2)]
    learners[0].fitness[:] = [1, 2, 3, 4, 5, 6]
    learners[1].fitness[:] = [10, 0, 0, 0, 0, 0]
    elites = global_elites(learners, 2)
    np.testing.assert_array_equal(elites[0], learners[1].population[0])
    np.testing.assert_array_equal(elites[1], learners[0].population[5])
    learners[0].index = 6
    learners[0].advance(ga.GAParams(population_size=6, tournament_size=2, elite_count=2), elites)
    np.testing.assert_array_equal(learners[0].population[:2], elites)
    assert learners[0].generation == 1 and learners[0].index == 0


def test_evidence_trusts_a_chromosome_driven_long_over_one_lucky_life():
    """Loss rate = (lives lost + 1) / (steps + 1), pooled over every vehicle that drove it."""
    driven_long, lucky, flawless = np.zeros(3), np.ones(3), np.full(3, 2.0)
    evidence = Evidence()
    evidence.record(lucky, 300, losses=0)
    evidence.record(driven_long, 500, losses=1)
    evidence.record(driven_long, 400, losses=0)  # another vehicle, life still going
    assert evidence.loss_rate(driven_long.tobytes()) == pytest.approx(2 / 901)
    assert evidence.loss_rate(lucky.tobytes()) == pytest.approx(1 / 301)
    np.testing.assert_array_equal(evidence.best(), driven_long)
    evidence.record(flawless, 2000, losses=0)
    np.testing.assert_array_equal(evidence.best(), flawless)


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
        learners, ga.GAParams(population_size=4, tournament_size=2), evidence=evidence))
    assert sum(evidence.steps.values()) == 2 * 30
    assert sum(evidence.losses.values()) == run.collisions.sum() + run.spins.sum() >= 1
    driven = {row.tobytes() for learner in learners
              for row in learner.population[: learner.index + 1]}
    assert set(evidence.chromosomes) == driven


def test_evolved_population_puts_the_ranked_candidates_first_without_repeats():
    from enn_traffic.experiments.simultaneous import _evolved_population

    a, b, c, d = (np.full(3, float(k)) for k in range(4))
    population = _evolved_population(np.stack([a, b]), np.stack([b, c, b, d]), size=3)
    np.testing.assert_array_equal(population, np.stack([a, b, c]))


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


def test_reduction_interval_follows_the_situations():
    import pandas as pd

    from enn_traffic.experiments.simultaneous import reduction_interval

    rng = np.random.default_rng(0)
    steady = pd.DataFrame({"strategy": [1, 1, 1, 2, 2], "initial": [1, 1, 1, 2, 2],
                           "population": [0.5, 0.5, 0.5, 0, 0]})
    assert reduction_interval(steady, "population", rng) == pytest.approx((0.75, 0.75))
    varied = pd.DataFrame({"strategy": [1] * 6, "initial": [1.0] * 6,
                           "population": [0.0, 0.0, 0.0, 0.4, 0.4, 0.4]})  # 80% on average
    low, high = reduction_interval(varied, "population", rng)
    assert 0.6 < low < 0.8 < high < 1.0


def test_ranking_keeps_what_validation_showed_of_each_candidate(world):
    """The winner of §5.5.1 is the candidate that lost fewest lives on the validation
    situations; each candidate's steps and lives lost there are kept as evidence for §5.5.2."""
    from enn_traffic.experiments import simultaneous

    straight = np.zeros(world.spec.chromosome_length)
    circling = straight.copy()
    circling[-1] = 1.0  # spins out (see the test above)
    candidates = np.stack([straight, circling])
    ranked, evidence = simultaneous._ranked(world, candidates)
    lost = {}
    for genes in world.spec.in_source_layout(candidates):  # the layout the arena drives
        runs = [simultaneous._broadcast(world, genes, s, simultaneous.VALIDATION_KEY)[0]
                for s in range(simultaneous.VALIDATION_SITUATIONS)]
        lost[genes.tobytes()] = sum(int(r.collisions.sum() + r.spins.sum()) for r in runs)
        assert evidence.steps[genes.tobytes()] == sum(r.vehicle_steps for r in runs)
        assert evidence.losses[genes.tobytes()] == lost[genes.tobytes()]
    assert len(set(lost.values())) == 2
    assert [lost[row.tobytes()] for row in world.spec.in_source_layout(ranked)] == sorted(
        lost.values())
