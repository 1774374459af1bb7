"""Choosing and accepting controllers (paper §5.3–5.4), through the experiments' public
functions."""

import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from enn_traffic.experiments import choosing, families
from enn_traffic.experiments.study import Study
from enn_traffic.learning.ga import GAState
from enn_traffic.runs.run import evolve


def test_candidates_are_every_generations_best_and_the_final_elites_each_once(small, tmp_path):
    evolve(small.with_overrides(ga={"generations": 4, "elite_count": 3}), tmp_path,
           progress=False)
    state = GAState.load(tmp_path / "checkpoint.npz")
    candidates = choosing.candidates(tmp_path)
    expected = {row.tobytes() for row in np.concatenate([state.champions,
                                                         state.population[:3]])}
    assert {row.tobytes() for row in candidates} == expected
    assert len(candidates) == len(expected)
    # the last generation's best is also the first elite, and comes once
    np.testing.assert_array_equal(state.champions[-1], state.population[0])
    assert len(candidates) <= 6


def test_the_pick_rechecks_its_short_list_and_keeps_the_best_worst_strategy():
    """Table 1 and 2 choose by the worst included strategy, on more traffic for the short list."""

    family = replace(families.ARENA, test_situations=2, recheck_situations=3)
    study = Study(Path("unused"))
    length = families.strategy_world(study, family, 1).spec.chromosome_length
    candidates = np.random.default_rng(0).uniform(-1, 1, size=(16, length))
    strategies = [1, 3]
    picked = choosing.pick(study, family, candidates, strategies)
    short = choosing.validation(study, family, candidates, strategies).min(axis=1)
    listed = candidates[np.argsort(-short, kind="stable")[: choosing.RECHECKED]]
    rechecked = choosing.validation(study, family, listed, strategies, 3).min(axis=1)
    assert any(np.array_equal(picked, row) for row in listed)
    assert choosing.validation(study, family, picked, strategies, 3).min() == rechecked.max()
    assert len(set(np.round(rechecked, 6))) > 1  # the recheck tells the short list apart


def test_table2_accepts_by_the_mean_less_standard_errors_on_other_situations():
    """§5.4.1's acceptance: the screen on validation traffic, then the bound on other traffic;
    a threshold between a candidate's bound and its mean there is refused."""
    from enn_traffic.sim.world import SPUN

    family = replace(families.ARENA, test_situations=2, recheck_situations=6)
    study = Study(Path("unused"))
    world = families.strategy_world(study, family, 1, 6)
    candidate = np.random.default_rng(3).uniform(-1, 1, size=(1, world.spec.chromosome_length))
    results = world.evaluate(candidate, choosing.ACCEPTANCE_KEY)
    fitness = np.where(results.outcome[0] == SPUN, 0.0, results.steps[0])
    mean, error = fitness.mean(), fitness.std(ddof=1) / math.sqrt(6)
    bound = choosing.lower_bound(study, family, candidate, 1, choosing.ACCEPTANCE_KEY, 6)
    assert bound[0] == pytest.approx(mean - choosing.ACCEPTANCE_ERRORS * error) and error > 0
    screen = choosing.validation(study, family, candidate, [1]).min()
    assert bound[0] < min(mean, screen)  # this candidate tells the bound from the mean
    assert choosing.accepts(study, family, candidate, [1], bound[0])
    assert not choosing.accepts(study, family, candidate, [1], 0.5 * (bound[0] + min(mean, screen)))
    assert not choosing.accepts(study, family, candidate, [1], screen + 1e-6)  # the screen refuses


def test_a_chromosome_is_driven_once_and_answers_as_a_fresh_world(monkeypatch):
    """The choice's lifetimes are the world's, whatever the order and repeats of the
    candidates; a chromosome asked about again is not driven again."""
    family = replace(families.ARENA, test_situations=3, recheck_situations=4)
    study = Study(Path("unused"))
    world = families.strategy_world(study, family, 2)
    pool = np.random.default_rng(5).uniform(-1, 1, size=(4, world.spec.chromosome_length))
    fresh = world.evaluate(pool, choosing.VALIDATION_KEY)
    asked = pool[[2, 0, 2, 1]]
    np.testing.assert_array_equal(
        choosing.mean_fitness(study, family, asked, 2, choosing.VALIDATION_KEY),
        fresh.fitness[[2, 0, 2, 1]])
    driven = []
    evaluate = world.evaluate
    monkeypatch.setattr(world, "evaluate", lambda p, key: driven.append(len(p)) or evaluate(p, key))
    again = choosing.mean_fitness(study, family, pool[[3, 1, 0]], 2, choosing.VALIDATION_KEY)
    np.testing.assert_array_equal(again, fresh.fitness[[3, 1, 0]])
    assert driven == [1]  # only pool[3] was new
    # a study of its own shares nothing with this one
    assert families.strategy_world(Study(Path("unused")), family, 2) is not world
    assert len(set(np.round(fresh.fitness, 6))) > 1  # the candidates drive differently
