"""Scoring controllers on the comparison's held-out situations: which situations (validation
and test keys, starts apart), and each controller's fitness on them, a GA chromosome's
through its world, a policy's through the vector environment."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pandas as pd

from enn_traffic.config import Scenario, TrackConfig
from enn_traffic.envs.rangefinder import RangefinderVectorEnv, rangefinder_world
from enn_traffic.experiments.gradient_rl.protocol import protocol as this_round
from enn_traffic.sim.world import SituationResults


def scoring_scenario(scenario: Scenario) -> Scenario:
    """The scenario validation and test situations are drawn from: ``scenario``, or, for a
    world without traffic and one start (every situation of it the same: the narrow track
    starts at one pose, §5.1), the same track started anywhere (every 5 m along its lanes,
    facing either way: ``track.start_anywhere``)."""
    track = scenario.track
    if (rangefinder_world(scenario).vehicles > 1 or not isinstance(track, TrackConfig)
            or track.start_anywhere or len(track.start_names) > 1):
        return scenario
    return scenario.with_overrides(track={"start_xy": None, "start_lane": None,
                                          "start_edge": None, "start_anywhere": True})


def situation_keys(scenario: Scenario, first_key: int, count: int, distinct: bool = False,
                   avoid: frozenset = frozenset()) -> list[int]:
    """The keys, from ``first_key`` on, whose situations (in order) hold ``count``. With
    ``distinct``, in a world that draws each situation's start from several, only keys whose
    starts are all new (to the keys before and to ``avoid``, a set of :func:`start_of`)."""
    world = rangefinder_world(scenario)
    per_key = len(world.situations(first_key))
    if not distinct or len(world.starts) == 1:
        return list(range(first_key, first_key + -(-count // per_key)))
    chosen, seen, key = [], set(avoid), first_key
    while len(chosen) * per_key < count:
        starts = [start_of(situation) for situation in world.situations(key)]
        if seen.isdisjoint(starts) and len(set(starts)) == len(starts):
            chosen.append(key)
            seen.update(starts)
        key += 1
        if key - first_key > 1000 * count:
            raise ValueError(f"{scenario.name}: too few starts for {count} situations that "
                             "share none")
    return chosen


def start_of(situation) -> tuple[float, float, float]:
    """The learner's start pose of a situation, rounded to the millimetre."""
    return tuple(np.round(situation.start[0], 3))


def held_out_keys(scenario: Scenario, keys_and_counts: dict | None = None
                  ) -> tuple[list[int], list[int]]:
    """The validation and the test keys of ``scenario``'s :func:`scoring_scenario` under
    ``keys_and_counts`` (a round's :func:`~enn_traffic.experiments.gradient_rl.protocol.
    protocol`, this round's by default): with distinct starts, the test keys avoid every
    validation start, and no start repeats within either."""
    protocol = keys_and_counts or this_round()
    scenario = scoring_scenario(scenario)
    distinct = bool(protocol.get("distinct_starts", False))
    validation = situation_keys(scenario, protocol["validation_key"],
                                protocol["validation_situations"], distinct)
    world = rangefinder_world(scenario)
    taken = frozenset(start_of(situation) for key in validation
                      for situation in world.situations(key)) if distinct else frozenset()
    test = situation_keys(scenario, protocol["test_key"], protocol["test_situations"],
                          distinct, taken)
    return validation, test


def chromosome_fitness(scenario: Scenario, chromosomes: np.ndarray, chosen_keys: list[int],
                       count: int) -> np.ndarray:
    """(C, count): each GA controller's fitness (steps lived, 0 for a spin) per situation of
    ``chosen_keys`` (in order, the first ``count``) of :func:`scoring_scenario`."""
    scenario = scoring_scenario(scenario)
    world = rangefinder_world(scenario)
    columns = []
    for key in chosen_keys:
        results = world.evaluate(chromosomes, key)
        columns.append(SituationResults.lifetime_fitness(results.steps, results.outcome))
    return np.concatenate(columns, axis=1)[:, :count]


def policy_lives(scenario: Scenario, act: Callable[[np.ndarray], np.ndarray],
                 keys: list[int], count: int | None = None, tail: int = 0,
                 observation_dtype: str = "float32") -> pd.DataFrame:
    """The first ``count`` situations of ``keys`` in ``scenario`` (in order; every one by
    default), each driven once by ``act`` (observations (N, B) → actions (N, 2)) through the
    vector environment: each life's steps, outcome and fitness (0 for a spin). A GA
    controller reads ``float64`` observations to live the lives :func:`chromosome_fitness`
    scores (its world's readings; ``float32`` ones part from them after hundreds of steps,
    :func:`observation_dtype`). With ``tail``,
    also where the learner went: ``distance`` (m) and ``tail_extent``, the larger of the x and
    y ranges of its last ``tail`` positions (m: a vehicle circling in place stays within its
    circle's diameter), and ``path``, its positions (steps, 2)."""
    if count is None:
        count = len(keys) * len(rangefinder_world(scenario).situations(keys[0]))
    env = RangefinderVectorEnv(scenario, count, observation_dtype=observation_dtype)
    observation, _ = env.reset(options={"keys": list(keys)})
    ended = {"steps": np.full(count, -1), "outcome": np.empty(count, dtype=object),
             "fitness": np.full(count, np.nan)}
    positions = []
    while (ended["steps"] < 0).any():
        if tail:
            positions.append(env.batch.worlds.pose[:, 0, :2].copy())
        observation, _, terminated, truncated, info = env.step(act(observation))
        for i in np.flatnonzero((terminated | truncated) & (ended["steps"] < 0)):
            for column, values in ended.items():
                values[i] = info["final_info"][column][i]
    table = pd.DataFrame(ended)
    if tail:
        path = np.stack(positions, axis=1)  # (count, steps, 2)
        lived = [path[i, :max(1, steps)] for i, steps in enumerate(ended["steps"])]
        table["distance"] = [np.linalg.norm(np.diff(p, axis=0), axis=1).sum() for p in lived]
        table["tail_extent"] = [np.ptp(p[-tail:], axis=0).max() for p in lived]
        table["path"] = lived
    return table


def policy_fitness(scenario: Scenario, act: Callable[[np.ndarray], np.ndarray],
                   chosen_keys: list[int], count: int) -> np.ndarray:
    """(count,): a policy's fitness per situation of ``chosen_keys`` (in order, the first
    ``count``) of :func:`scoring_scenario` (:func:`policy_lives`)."""
    return policy_lives(scoring_scenario(scenario), act, chosen_keys, count)[
        "fitness"].to_numpy()


def observation_dtype(method: str) -> str:
    """The observations a method's controllers are scored on in the comparison: the GA's
    world's ``float64`` readings (:func:`chromosome_fitness`), the vector environment's
    ``float32`` ones for the policies it trained."""
    return "float64" if method == "GA" else "float32"
