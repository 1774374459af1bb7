import math

import numpy as np
import pandas as pd
import pytest

from enn_traffic.errors import InputError
from enn_traffic.evolution.ga import GAState
from enn_traffic.runner import evolve
from enn_traffic.scenario import load_scenario


@pytest.fixture
def small(root):
    return load_scenario(root / "scenarios" / "navigation_narrow.toml").with_overrides(
        ga={"population_size": 30, "generations": 40})


def test_target_fitness_stops_the_run_and_resume_keeps_it_stopped(small, tmp_path):
    scenario = small.with_overrides(ga={"target_fitness": 40.0})
    table = evolve(scenario, tmp_path, progress=False)
    assert table["best_fitness"].iloc[-1] >= 40 and (table["best_fitness"].iloc[:-1] < 40).all()
    assert len(table) < 40
    again = evolve(scenario, tmp_path, resume=True, progress=False)
    pd.testing.assert_frame_equal(table, again)


def test_initial_population_seeds_a_fresh_run(small, tmp_path):
    first = evolve(small.with_overrides(ga={"generations": 3}), tmp_path / "a", progress=False)
    population = GAState.load(tmp_path / "a" / "checkpoint.npz").population
    continued = evolve(small.with_overrides(ga={"generations": 1}), tmp_path / "b",
                       progress=False, initial_population=population)
    fresh = evolve(small.with_overrides(ga={"generations": 1}), tmp_path / "c", progress=False)
    assert continued["mean_fitness"].iloc[0] != fresh["mean_fitness"].iloc[0]
    assert len(first) == 3
    with pytest.raises(ValueError, match="initial population has shape"):
        evolve(small, tmp_path / "d", progress=False, initial_population=np.zeros((3, 3)))


def test_stop_hook_sees_the_evaluated_population_and_champions_are_its_fittest(small, tmp_path):
    seen = []

    def stop(population, fitness):
        seen.append((population.copy(), fitness.copy()))
        return len(seen) == 3

    table = evolve(small, tmp_path, progress=False, stop=stop)
    assert len(table) == 3
    assert all(p.shape == (30, 68) and f.shape == (30,) for p, f in seen)
    assert [f.max() for _, f in seen] == table["best_fitness"].tolist()
    champions = GAState.load(tmp_path / "checkpoint.npz").champions
    assert champions.shape == (3, 68)
    for champion, (population, fitness) in zip(champions, seen, strict=True):
        np.testing.assert_array_equal(champion, population[np.argmax(fitness)])


def test_a_run_is_resumed_only_from_the_same_start_and_other_worlds(small, tmp_path, root):
    """Incremental evolution's runs depend on the population they start from and on the other
    worlds they are judged in: a resume with either changed is refused, not silently reused."""
    scenario = small.with_overrides(ga={"generations": 2})
    population = np.random.default_rng(1).uniform(-1, 1, (30, 68))
    wide = load_scenario(root / "scenarios" / "navigation_wide.toml")
    evolve(scenario, tmp_path, progress=False, initial_population=population, others=[wide])
    again = evolve(scenario, tmp_path, resume=True, progress=False,
                   initial_population=population, others=[wide])
    assert len(again) == 2
    # the other worlds' own number of generations plays no part in this run
    longer = wide.with_overrides(ga={"generations": wide.ga.generations + 50})
    again = evolve(scenario, tmp_path, resume=True, progress=False,
                   initial_population=population, others=[longer])
    pd.testing.assert_frame_equal(again, evolve(scenario, tmp_path, resume=True, progress=False,
                                                initial_population=population, others=[wide]))
    changes = [{"initial_population": population * 0.5, "others": [wide]},
               {"initial_population": population, "others": []},
               {"initial_population": population,
                "others": [wide.with_overrides(sensor={"range": 20.0})]}]
    for change in changes:
        with pytest.raises(InputError, match="different settings"):
            evolve(scenario, tmp_path, resume=True, progress=False, **change)


def test_candidates_are_every_generations_best_and_the_final_elites_each_once(small, tmp_path):
    from enn_traffic.experiments.dynamic import _candidates

    evolve(small.with_overrides(ga={"generations": 4, "elite_count": 3}), tmp_path,
           progress=False)
    state = GAState.load(tmp_path / "checkpoint.npz")
    candidates = _candidates(tmp_path)
    expected = {row.tobytes() for row in np.concatenate([state.champions,
                                                         state.population[:3]])}
    assert {row.tobytes() for row in candidates} == expected
    assert len(candidates) == len(expected)
    # the last generation's best is also the first elite, and comes once
    np.testing.assert_array_equal(state.champions[-1], state.population[0])
    assert len(candidates) <= 6


def test_the_pick_rechecks_its_short_list_and_keeps_the_best_worst_strategy():
    """Table 1 and 2 choose by the worst included strategy, on more traffic for the short list."""
    from dataclasses import replace

    from enn_traffic.experiments import dynamic

    family = replace(dynamic.ARENA, test_episodes=2, recheck_episodes=3)
    length = dynamic._test_world(family, 1).spec.chromosome_length
    candidates = np.random.default_rng(0).uniform(-1, 1, size=(16, length))
    strategies = [1, 3]
    picked = dynamic._pick(family, candidates, strategies)
    short = dynamic._validation(family, candidates, strategies).min(axis=1)
    listed = candidates[np.argsort(-short, kind="stable")[: dynamic.RECHECKED]]
    rechecked = dynamic._validation(family, listed, strategies, 3).min(axis=1)
    assert any(np.array_equal(picked, row) for row in listed)
    assert dynamic._validation(family, picked, strategies, 3).min() == rechecked.max()
    assert len(set(np.round(rechecked, 6))) > 1  # the recheck tells the short list apart


def test_table2_accepts_by_the_mean_less_standard_errors_on_other_situations():
    """§5.4.1's acceptance: the screen on validation traffic, then the bound on other traffic;
    a threshold between a candidate's bound and its mean there is refused."""
    from dataclasses import replace

    from enn_traffic.experiments import dynamic
    from enn_traffic.sim.world import SPUN

    family = replace(dynamic.ARENA, test_episodes=2, recheck_episodes=6)
    world = dynamic._test_world(family, 1, 6)
    candidate = np.random.default_rng(3).uniform(-1, 1, size=(1, world.spec.chromosome_length))
    results = world.evaluate(candidate, dynamic.ACCEPTANCE_KEY)
    fitness = np.where(results.outcome[0] == SPUN, 0.0, results.steps[0])
    mean, error = fitness.mean(), fitness.std(ddof=1) / math.sqrt(6)
    bound = dynamic._lower_bound(family, candidate, 1, dynamic.ACCEPTANCE_KEY, 6)
    assert bound[0] == pytest.approx(mean - dynamic.ACCEPTANCE_ERRORS * error) and error > 0
    screen = dynamic._validation(family, candidate, [1]).min()
    assert bound[0] < min(mean, screen)  # this candidate tells the bound from the mean
    assert dynamic._accepts(family, candidate, [1], bound[0])
    assert not dynamic._accepts(family, candidate, [1], 0.5 * (bound[0] + min(mean, screen)))
    assert not dynamic._accepts(family, candidate, [1], screen + 1e-6)  # the screen refuses


def test_table2_evolves_a_wider_network_than_table1():
    """Table 2's one controller must hold every strategy's skill: its worlds are built with the
    family's incremental hidden layer, Table 1's with the scenarios' own (Figure 1's count)."""
    from enn_traffic.experiments import dynamic

    incremental = dynamic.ARENA.incremental()
    (hidden,) = dynamic.ARENA.incremental_hidden
    assert dynamic.ARENA.scenario(2).network.hidden == [3] and hidden != 3
    # (19 beams + bias) x hidden + (hidden + bias) x 2 outputs
    assert dynamic._test_world(incremental, 2, 1).spec.chromosome_length == 20 * hidden + (
        hidden + 1) * 2
    assert dynamic._test_world(dynamic.ARENA, 2, 1).spec.chromosome_length == 20 * 3 + 4 * 2


def test_table2_reports_the_evolution_whose_last_controller_does_best_on_validation(tmp_path):
    """One incremental evolution per seed; table2.csv is the one whose last controller's worst
    strategy does best on validation traffic, table2_runs.csv holds them all."""
    from enn_traffic.experiments import dynamic

    dynamic.table2(tmp_path, quick=True, progress=False)
    runs = pd.read_csv(tmp_path / "table2_runs.csv")
    family = dynamic.ARENA.settings(True).incremental()
    assert sorted(runs["seed"].unique()) == list(family.incremental_seeds) == [1, 2]
    worst = {}
    for seed in family.incremental_seeds:
        last = tmp_path / "runs" / "incremental" / f"seed{seed}" / "iteration4"
        chosen = dynamic._pick(family, dynamic._candidates(last), dynamic.STRATEGIES)
        worst[seed] = dynamic._validation(family, chosen, dynamic.STRATEGIES,
                                          family.recheck_episodes).min()
    assert worst[1] != worst[2]  # the two evolutions are told apart
    best = max(worst, key=worst.get)
    expected = runs[runs["seed"] == best].drop(columns="seed").reset_index(drop=True)
    pd.testing.assert_frame_equal(pd.read_csv(tmp_path / "table2.csv"), expected)
