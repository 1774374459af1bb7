"""Learning while driving: each vehicle's own GA, the shared elites, the pooled evidence
(paper §5.5)."""

import numpy as np
import pytest
from conftest import two_cars

from enn_traffic.config import GAConfig
from enn_traffic.learning.online import Evidence, VehicleGA, global_elites


@pytest.fixture
def world(tmp_path, root):
    return two_cars(tmp_path, root, (20.0, 50.0), (40.0, 50.0), 180.0)


def test_exhausted_population_breeds_with_the_global_elites(world):
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
    learners[0].advance(GAConfig(population_size=6, tournament_size=2, elite_count=2), elites)
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


def test_after_learning_a_vehicle_drives_the_fittest_of_its_last_whole_generation(world):
    """The authors' rule (reference §7.5): the best of the generation it last bred from, not of
    the one it is trying; before any, the best it has tried of its first."""
    length = world.spec.chromosome_length
    population = np.arange(4 * length, dtype=float).reshape(4, length)
    learner = VehicleGA(population.copy(), np.random.default_rng(0))
    np.testing.assert_array_equal(learner.evolved(), population[0])  # nothing tried yet
    for fitness in (5.0, 9.0):
        learner.record(fitness)
    np.testing.assert_array_equal(learner.evolved(), population[1])
    for fitness in (7.0, 9.0):
        learner.record(fitness)
    learner.advance(GAConfig(population_size=4, tournament_size=2, elite_count=1))
    learner.record(100.0)  # the new generation's first: not whole yet
    np.testing.assert_array_equal(learner.evolved(), population[1])  # first of the two 9s
    assert (learner.generation, learner.tried) == (1, 5)


def test_the_authors_finishing_rule_keeps_a_chromosome_that_lived_2000_steps(world):
    """Reference §7.5: a life of ``finish_steps`` or more (not a spin) finishes the vehicle;
    it keeps that chromosome through later lives, breeds no more, and drives it after
    learning; a life still going that long at the end finishes it too."""
    from enn_traffic.learning.online import OnlineLearning

    length = world.spec.chromosome_length
    params = GAConfig(population_size=3, tournament_size=2)

    def learning() -> OnlineLearning:
        population = np.arange(3 * length, dtype=float).reshape(3, length)
        return OnlineLearning([VehicleGA(population, np.random.default_rng(0))], params,
                              finish_steps=2000)

    online = learning()
    np.testing.assert_array_equal(online.life_ended(0, 1999, 1999, spun=False),
                                  online.learners[0].population[1])  # not yet: the next
    np.testing.assert_array_equal(online.life_ended(0, 2600, 2600, spun=True),
                                  online.learners[0].population[2])  # a spin scores 0
    kept = online.life_ended(0, 2000, 2000, spun=False)
    np.testing.assert_array_equal(kept, online.learners[0].population[2])
    for _ in range(5):  # more lives than the population: no generation is bred
        np.testing.assert_array_equal(online.life_ended(0, 10, 10, spun=False), kept)
    learner = online.learners[0]
    assert learner.finished and learner.generation == 0 and learner.lives == 8
    np.testing.assert_array_equal(learner.evolved(), kept)
    assert online.learner_rows()[0]["finished"] == 1

    online = learning()
    online.still_driving(0, 1500, life_steps=1500)
    assert not online.learners[0].finished
    online.still_driving(0, 600, life_steps=2100)
    assert online.learners[0].finished
    np.testing.assert_array_equal(online.learners[0].evolved(), online.learners[0].population[0])


def test_the_authors_breeding_never_takes_a_parent_from_the_worst(world):
    """Breeding from the best P − E (reference §7.4): with tournaments of one (a parent drawn
    at random) no child carries a gene of the worst E, whose genes are all 5 (a value that
    mutation, drawing from [−1, 1], never writes); drawing from all P, children do."""
    length = world.spec.chromosome_length
    params = GAConfig(population_size=20, tournament_size=1, elite_count=4)
    elites = np.full((4, length), 0.5)

    def children(from_best: bool) -> np.ndarray:
        learner = VehicleGA(np.random.default_rng(1).uniform(-1, 1, (20, length)),
                            np.random.default_rng(2))
        learner.population[16:] = 5.0
        learner.fitness[:] = np.r_[np.arange(16) + 10.0, np.zeros(4)]
        learner.index = 20
        learner.advance(params, elites, from_best)
        np.testing.assert_array_equal(learner.population[:4], elites)
        assert len(learner.population) == 20 and learner.generation == 1
        return learner.population[4:]

    assert not (children(True) == 5.0).any()
    assert (children(False) == 5.0).any()
