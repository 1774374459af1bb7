"""Fixed populations driven through every kind of world; the arrays they give.

``tests/data/behaviour.npz`` holds these arrays as the code gave them before the step rules were
written once (issue 23); ``test_behaviour.py`` checks that today's code gives the same. Run this
file to write the arrays afresh (only when a change of behaviour is meant and said)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
GOLDEN = ROOT / "tests" / "data" / "behaviour.npz"
ARENAS = ("arena_strategy1", "arena_strategy2", "arena_strategy3", "arena_strategy4",
          "navigation_narrow")


def _scenario(name: str, **overrides):
    from enn_traffic.config import load_scenario

    return load_scenario(ROOT / "scenarios" / f"{name}.toml").with_overrides(**overrides)


def _population(world, size: int, seed: int) -> np.ndarray:
    return np.random.default_rng(seed).uniform(-1, 1, (size, world.spec.chromosome_length))


def _results(prefix: str, results, out: dict) -> None:
    for field in ("fitness", "steps", "outcome", "suffered", "traffic"):
        out[f"{prefix}/{field}"] = np.asarray(getattr(results, field))


def behaviour() -> dict[str, np.ndarray]:
    """Lifetimes, outcomes, collisions suffered, traffic met and traces, world by world."""
    from enn_traffic.sim.arena import ArenaWorld as World
    from enn_traffic.sim.lane_keeping.world import LaneKeepingWorld
    from enn_traffic.sim.sumo.world import SumoWorld

    out: dict[str, np.ndarray] = {}
    for name in ARENAS:  # one learner per world among scripted or network traffic
        world = World(_scenario(name, episode={"max_steps": 400}))
        population = _population(world, 6, 0)
        for key in (0, 7):
            _results(f"{name}/{key}", world.evaluate(population, key), out)
        trace, outcome = world.trace(population[1], 7, 0, max_steps=150)
        out[f"{name}/trace"], out[f"{name}/trace_outcome"] = trace, np.array(outcome)

    for mode in ("replay", "closed-loop"):  # the learner among SUMO's traffic
        world = SumoWorld(_scenario("sumo_strategy1", episode={"max_steps": 250},
                                    traffic={"mode": mode, "episodes": 1}))
        population = _population(world, 4 if mode == "replay" else 2, 1)
        _results(f"sumo_{mode}", world.evaluate(population, 3), out)
        trace, outcome = world.trace(population[0], 3, 0, max_steps=120)
        out[f"sumo_{mode}/trace"] = np.nan_to_num(trace, nan=-1e9)
        out[f"sumo_{mode}/trace_outcome"] = np.array(outcome)

    out.update(_many_learners())

    world = LaneKeepingWorld(_scenario("lane_keeping", episode={"max_steps": 120}))
    population = _population(world, 3, 2)
    _results("lane_keeping", world.evaluate(population, 1), out)
    trace, outcome = world.trace(population[0], 1, 0, max_steps=60)
    out["lane_keeping/trace"], out["lane_keeping/trace_outcome"] = trace, np.array(outcome)
    return out


def _many_learners() -> dict[str, np.ndarray]:
    """Every vehicle of one arena driving at once, half of them learning as they drive."""
    from enn_traffic.learning.online import Evidence, OnlineLearning, VehicleGA
    from enn_traffic.sim.arena import ArenaWorld as World
    from enn_traffic.sim.crowd import Crowd as Arena

    def arena(world, key, kinds=None):
        episode = world.situations(key)[0]
        kinds = episode.kinds.copy() if kinds is None else kinds
        kinds[0] = kinds[1]  # the learner's place is driven as the others are
        return Arena(world, episode.start, kinds, int(episode.seed)), episode.traffic_genes.copy()

    out = {}
    for name in ("arena_strategy1", "arena_strategy4"):
        world = World(_scenario(name, ga={"population_size": 6, "elite_count": 2,
                                          "tournament_size": 2}))
        arena_, genes = arena(world, 11)
        run = arena_.run(20.0, genes)
        out[f"many_{name}/collisions"], out[f"many_{name}/trace"] = run.collisions, run.trace
        arena_, _ = arena(world, 12, np.full(world.vehicles, 1))  # network drivers
        pool = world.spec.in_source_layout(_population(world, 6, 3))
        learners = [VehicleGA(pool.copy(), np.random.default_rng(v)) if v % 2 else None
                    for v in range(world.vehicles)]
        evidence = Evidence()
        learning = OnlineLearning(learners, world.scenario.ga, share_elites=True,
                                  elite_count=2, evidence=evidence)
        run = arena_.run(30.0, np.tile(pool[0], (world.vehicles, 1)), learning)
        out[f"many_{name}/learning_collisions"] = run.collisions
        out[f"many_{name}/learning_spins"] = run.spins
        out[f"many_{name}/learning_trace"] = run.trace
        out[f"many_{name}/best"] = evidence.best()
        for field in ("fitness", "population"):
            out[f"many_{name}/learner_{field}"] = np.concatenate(
                [getattr(g, field) for g in learners if g is not None])
    return out


if __name__ == "__main__":
    np.savez_compressed(GOLDEN, **behaviour())
    print(f"wrote {GOLDEN}")
