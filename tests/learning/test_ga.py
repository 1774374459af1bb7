import numpy as np
import pytest

from enn_traffic.config import GAConfig
from enn_traffic.learning import ga


def test_tournament_of_whole_population_always_picks_the_best():
    rng = np.random.default_rng(0)
    fitness = np.array([3.0, 9.0, 1.0, 4.0])
    winners = ga.tournament_select(rng, fitness, count=500, tournament_size=40)
    assert np.all(winners == 1)


def test_tournament_size_one_is_uniform():
    rng = np.random.default_rng(1)
    winners = ga.tournament_select(rng, np.arange(10.0), count=20_000, tournament_size=1)
    counts = np.bincount(winners, minlength=10)
    assert counts.min() > 1700 and counts.max() < 2300


def test_crossover_cut_follows_normal_095_005():
    rng = np.random.default_rng(2)
    length, pairs = 68, 20_000
    first, second = np.zeros((pairs, length)), np.ones((pairs, length))
    children = ga.one_point_crossover(rng, first, second, 1.0, 0.95, 0.05)
    child_a, child_b = children[:pairs], children[pairs:]
    np.testing.assert_array_equal(child_a + child_b, 1.0)  # complementary children
    cut = length - child_a.sum(axis=1)  # genes taken from the second parent start at the cut
    # round(N(0.95, 0.05) * 68) clipped to [1, 67]: the clip at 67 pulls the mean below 64.6
    expected = np.clip(np.rint(np.random.default_rng(99).normal(0.95, 0.05, 10**6) * 68), 1, 67)
    assert abs(cut.mean() - expected.mean()) < 0.1
    assert abs(cut.std() - expected.std()) < 0.1
    assert abs((cut == 67).mean() - (expected == 67).mean()) < 0.02
    assert cut.min() >= 1 and cut.max() <= length - 1


def test_crossover_probability_zero_copies_parents():
    rng = np.random.default_rng(3)
    a, b = rng.random((5, 10)), rng.random((5, 10))
    children = ga.one_point_crossover(rng, a, b, 0.0, 0.95, 0.05)
    np.testing.assert_array_equal(children, np.concatenate([a, b]))


def test_mutation_replaces_a_tenth_of_genes_within_range():
    rng = np.random.default_rng(4)
    population = np.full((400, 68), 5.0)
    mutated = ga.mutate(rng, population, 0.1, 1.0)
    changed = mutated != 5.0
    assert abs(changed.mean() - 0.1) < 0.01
    assert np.all(np.abs(mutated[changed]) <= 1.0)


def test_elites_survive_unchanged():
    rng = np.random.default_rng(5)
    population = rng.uniform(-1, 1, (20, 8))
    fitness = rng.random(20)
    params = GAConfig(population_size=20, elite_count=2, mutation_probability=1.0)
    child = ga.next_generation(rng, population, fitness, params)
    assert child.shape == population.shape
    top = np.argsort(-fitness)[:2]
    np.testing.assert_array_equal(child[:2], population[top])


def test_same_seed_same_generation():
    def one(seed):
        rng = np.random.default_rng(seed)
        population = ga.initial_population(rng, 30, 12, 1.0)
        params = GAConfig(population_size=30, tournament_size=5)
        return ga.next_generation(rng, population, population.sum(axis=1), params)

    np.testing.assert_array_equal(one(7), one(7))
    assert not np.array_equal(one(7), one(8))


def test_ga_improves_fitness_on_a_small_problem():
    """Maximise -||x - target||^2 over 10 genes: the paper's operators must make progress."""
    rng = np.random.default_rng(6)
    target = rng.uniform(-1, 1, 10)
    params = GAConfig(population_size=60, tournament_size=4, elite_count=1)
    population = ga.initial_population(rng, 60, 10, 1.0)
    first = None
    for _ in range(60):
        fitness = -((population - target) ** 2).sum(axis=1)
        first = fitness.max() if first is None else first
        population = ga.next_generation(rng, population, fitness, params)
    final = (-((population - target) ** 2).sum(axis=1)).max()
    assert final > first / 10  # the best squared error shrank at least tenfold


def test_ask_and_tell_drive_a_run_to_the_target_and_keep_its_best():
    """The GA's loop (:func:`ga.generations`: ask, evaluate, tell) on the same problem: the
    state's best is the fittest chromosome ever evaluated, each generation's champion is its
    fittest, and the best squared error shrinks tenfold."""
    rng = np.random.default_rng(6)
    target = rng.uniform(-1, 1, 10)

    class Scored:
        def __init__(self, population, generation):
            self.fitness = -((population - target) ** 2).sum(axis=1)
            self.generation = generation

    params = GAConfig(population_size=60, tournament_size=4, elite_count=1)
    state = ga.GAState(generation=0, population=ga.initial_population(rng, 60, 10, 1.0), rng=rng)
    seen, run = [], ga.generations(state, Scored, params)
    for number in range(60):
        state, population, scored = next(run)
        assert scored.generation == number and state.generation == number + 1
        seen.append((population, scored.fitness))
        np.testing.assert_array_equal(state.champions[-1], population[np.argmax(scored.fitness)])
    fitness = np.concatenate([f for _, f in seen])
    assert state.best_fitness == fitness.max()
    assert np.array_equal(state.best_chromosome, np.concatenate([p for p, _ in seen])[
        np.argmax(fitness)])
    assert len(state.champions) == 60 and state.best_fitness > seen[0][1].max() / 10


def test_tell_breeds_as_next_generation_does():
    """tell's children are next_generation's from the same generator state."""
    population = ga.initial_population(np.random.default_rng(1), 30, 12, 1.0)
    fitness = population.sum(axis=1)
    params = GAConfig(population_size=30, tournament_size=5, elite_count=2)
    told = ga.tell(ga.GAState(4, population, np.random.default_rng(9)), fitness, params)
    bred = ga.next_generation(np.random.default_rng(9), population, fitness, params)
    np.testing.assert_array_equal(told.population, bred)
    assert told.generation == 5 and told.best_fitness == fitness.max()


def test_checkpoint_round_trip_and_corruption(tmp_path):
    from enn_traffic.core.errors import InputError

    rng = np.random.default_rng(9)
    state = ga.GAState(generation=4, population=rng.random((6, 3)), rng=rng,
                       best_chromosome=np.ones(3), best_fitness=12.0, fingerprint="abc",
                       champions=rng.random((4, 3)))
    path = tmp_path / "checkpoint.npz"
    state.save(path)
    loaded = ga.GAState.load(path)
    assert loaded.generation == 4 and loaded.fingerprint == "abc"
    np.testing.assert_array_equal(loaded.champions, state.champions)
    np.testing.assert_array_equal(loaded.population, state.population)
    assert loaded.rng.random() == rng.random()  # generator continues identically
    path.write_bytes(path.read_bytes()[:100])
    with pytest.raises(InputError, match="corrupted"):
        ga.GAState.load(path)
