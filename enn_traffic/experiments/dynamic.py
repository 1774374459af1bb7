"""Paper §5.3–5.4: collision avoidance among dynamic vehicles in the arena — learning curves
per traffic strategy (Fig. 11), deployment on unseen strategies (Table 1, Fig. 12), and
incremental evolution over strategies (Table 2)."""

from __future__ import annotations

from functools import cache
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd

from enn_traffic.evaluation import EVALUATION_KEY
from enn_traffic.evolution.ga import GAState
from enn_traffic.experiments.common import run_or_reuse, scenario, seed_runs
from enn_traffic.io import write_csv
from enn_traffic.report.plots import draw_paths, learning_curves, save_figure
from enn_traffic.scenario import load_scenario
from enn_traffic.sim.world import World

STRATEGIES = [1, 2, 3, 4]
SEEDS = [1, 2, 3, 4]
QUICK = {"population_size": 40, "generations": 12, "elite_count": 4}
TEST_EPISODES = 40
# Candidates are chosen on validation traffic, never on the test traffic of Tables 1 and 2.
VALIDATION_KEY = 2_000_000_000
# Table 2 (§5.4.1): a strategy is added once the fitness on every strategy included so far
# exceeds 80% of the accepted fitness, judged on validation traffic (TEST_EPISODES per
# strategy) for the TOP_CANDIDATES fittest of a generation, since a generation's best fitness
# alone is mostly luck.
ACCEPTED_FITNESS = 750.0
INCREMENTAL_MAX_GENERATIONS = 40
TOP_CANDIDATES = 5


def _name(strategy: int) -> str:
    return f"arena_strategy{strategy}"


def _seeds(quick: bool) -> list[int]:
    return SEEDS[:2] if quick else SEEDS


def _strategy_runs(strategy: int, out: Path, quick: bool, progress: bool):
    return seed_runs(_name(strategy), out, _seeds(quick), QUICK if quick else {}, progress)


@cache
def _test_world(strategy: int) -> World:
    """The world of a strategy with ``TEST_EPISODES`` traffic situations, built once."""
    return World(scenario(_name(strategy)).with_overrides(traffic={"episodes": TEST_EPISODES}))


def _mean_fitness(candidates: np.ndarray, strategy: int, key: int) -> np.ndarray:
    """Mean fitness of each candidate over the test episodes drawn from ``key``."""
    return _test_world(strategy).evaluate(np.atleast_2d(candidates), key).fitness


def _candidates(run_dir: Path) -> np.ndarray:
    """A run's best chromosome and the elites at the head of its final population."""
    state = GAState.load(run_dir / "checkpoint.npz")
    elites = load_scenario(run_dir / "scenario.toml").ga.elite_count
    rows = [state.population[: max(elites, 1)]]
    if state.best_chromosome is not None:
        rows.insert(0, state.best_chromosome[None, :])
    return np.concatenate(rows)


def _validation(candidates: np.ndarray, strategies: list[int]) -> np.ndarray:
    """Mean fitness (candidates, strategies) on validation traffic."""
    return np.stack([_mean_fitness(candidates, s, VALIDATION_KEY) for s in strategies], axis=1)


def _pick(candidates: np.ndarray, strategies: list[int]) -> np.ndarray:
    """The candidate with the best mean validation fitness over ``strategies``."""
    return candidates[int(np.argmax(_validation(candidates, strategies).mean(axis=1)))]


def _test_fitness(chromosome: np.ndarray, strategy: int) -> float:
    """Mean fitness over ``TEST_EPISODES`` test episodes of a strategy's traffic."""
    return float(_mean_fitness(chromosome, strategy, EVALUATION_KEY)[0])


def fig11(out: Path, quick: bool = False, progress: bool = True) -> list[str]:
    """Learning curves, 4 runs per strategy, one panel per strategy."""
    figure, axes = plt.subplots(2, 2, figsize=(10, 7), sharex=True)
    rows = []
    for strategy, ax in zip(STRATEGIES, axes.ravel(), strict=True):
        runs = _strategy_runs(strategy, out, quick, progress)
        learning_curves({f"seed {s}": t for s, t in runs.items()}, None, axes=ax,
                        title=f"strategy {strategy}: {scenario(_name(strategy)).traffic.strategy}")
        for seed, table in runs.items():
            best = table["best_fitness"]
            rows.append({
                "strategy": strategy, "seed": seed, "generations": len(table),
                "first_best": best.iloc[0], "last_best": best.iloc[-1],
                "last5_mean_best": best.tail(5).mean(), "max_best": best.max(),
                "rise": best.tail(5).mean() / max(best.iloc[0], 1.0),
            })  # fmt: skip
    figure.suptitle("Fig. 11: learner among 7 uncontrolled vehicles, 4 runs per strategy")
    figure.tight_layout()
    save_figure(figure, out / "fig11.png")
    table = pd.DataFrame(rows)
    write_csv(out / "fig11.csv", table)
    rise = table.groupby("strategy")["rise"].median()
    return ["fig11: best fitness, mean of the last 5 generations over the first generation's "
            "(median of the runs): "
            + ", ".join(f"strategy {s}: {r:.1f}x" for s, r in rise.items())]


def _trained_controllers(out: Path, quick: bool, progress: bool) -> dict[int, np.ndarray]:
    """Per strategy: the best of its runs' candidates, judged on validation traffic of that
    same strategy."""
    chosen = {}
    for strategy in STRATEGIES:
        _strategy_runs(strategy, out, quick, progress)
        candidates = np.concatenate([
            _candidates(out / "runs" / _name(strategy) / f"seed{seed}") for seed in _seeds(quick)])
        chosen[strategy] = _pick(candidates, [strategy])
    return chosen


def _draw_specialists(controllers: dict[int, np.ndarray], path: Path, steps: int = 400) -> None:
    """Each strategy's chosen controller among its own traffic (first test episode)."""
    figure, axes = plt.subplots(1, 4, figsize=(16, 4.4))
    for strategy, ax in zip(STRATEGIES, axes, strict=True):
        world = _test_world(strategy)
        poses, _ = world.trace(controllers[strategy], EVALUATION_KEY, max_steps=steps)
        traffic = [poses[:, v] for v in range(1, poses.shape[1])]
        draw_paths(ax, world.track.walls, [*traffic, poses[:, 0]],
                   colors=["0.6"] * len(traffic) + ["C3"])
        ax.set_xticks([])
        ax.set_yticks([])
        ax.set_title(f"strategy {strategy}: {len(poses) - 1} steps", fontsize=9)
    figure.suptitle(f"Each strategy's controller (red) among its traffic (grey), first {steps} "
                    "steps of a test episode")
    figure.tight_layout()
    save_figure(figure, path)


def table1(out: Path, quick: bool = False, progress: bool = True) -> list[str]:
    """Train on each strategy, deploy on each (Table 1), and the colour map (Fig. 12)."""
    controllers = _trained_controllers(out, quick, progress)
    matrix = np.array([[_test_fitness(controllers[trained], deployed)
                        for deployed in STRATEGIES] for trained in STRATEGIES])
    table = pd.DataFrame(matrix.round(1), columns=[f"deploy_{s}" for s in STRATEGIES])
    table.insert(0, "training_strategy", STRATEGIES)
    write_csv(out / "table1.csv", table)
    figure, ax = plt.subplots(figsize=(5, 4.2))
    image = ax.imshow(matrix, cmap="viridis")
    ax.set_xticks(range(4), [str(s) for s in STRATEGIES])
    ax.set_yticks(range(4), [str(s) for s in STRATEGIES])
    ax.set_xlabel("deployment strategy")
    ax.set_ylabel("training strategy")
    for i in range(4):
        for j in range(4):
            ax.text(j, i, f"{matrix[i, j]:.0f}", ha="center", va="center", color="white")
    figure.colorbar(image, label="mean fitness [steps]")
    ax.set_title("Fig. 12: fitness on seen and unseen strategies")
    figure.tight_layout()
    save_figure(figure, out / "fig12.png")
    _draw_specialists(controllers, out / "arena_paths.png")
    diagonal = np.diag(matrix)
    off = matrix[~np.eye(4, dtype=bool)]
    rows_ok = sum(diagonal[i] > np.delete(matrix[i], i).max() for i in range(4))
    return [f"table1: mean diagonal {diagonal.mean():.0f}, mean off-diagonal {off.mean():.0f} "
            f"(ratio {diagonal.mean() / off.mean():.1f}; paper 4.9); diagonal above the rest "
            f"of its row in {rows_ok} of 4 rows (paper: 4 of 4)"]


def table2(out: Path, quick: bool = False, progress: bool = True) -> list[str]:
    """Incremental evolution: add a strategy each time the fitness passes 80% of the accepted
    fitness; the fitness is averaged over the strategies included so far (§5.4.1)."""
    names = [scenario(_name(s)).traffic.strategy for s in STRATEGIES]
    threshold = 0.8 * ACCEPTED_FITNESS
    base = scenario(_name(1))
    population, rows = None, []
    for iteration in range(1, len(STRATEGIES) + 1):
        ga = {"generations": INCREMENTAL_MAX_GENERATIONS, **(QUICK if quick else {})}
        sc = base.with_overrides(name=f"incremental_{iteration}", ga=ga,
                                 traffic={"strategy": names[:iteration]})
        included = STRATEGIES[:iteration]

        def accepted(population, fitness, included=included):
            top = population[np.argsort(-fitness, kind="stable")[:TOP_CANDIDATES]]
            return bool(_validation(top, included).min(axis=1).max() >= threshold)

        run_dir = out / "runs" / "incremental" / f"iteration{iteration}"
        table = run_or_reuse(sc, run_dir, progress, initial_population=population, stop=accepted)
        state = GAState.load(run_dir / "checkpoint.npz")
        population = state.population
        chosen = _pick(_candidates(run_dir), included)
        row = {"iteration": iteration, "generations": len(table),
               "reached_threshold": bool(state.extra.get("target_reached", False))}
        per_strategy = []
        for strategy in STRATEGIES:
            value = _test_fitness(chosen, strategy) if strategy <= iteration else np.nan
            row[f"strategy_{strategy}"] = value
            per_strategy.append(value)
        row["average"] = float(np.nanmean(per_strategy))
        rows.append(row)
    table = pd.DataFrame(rows)
    write_csv(out / "table2.csv", table.round(1))
    last = table.iloc[-1]
    kept = all(last[f"strategy_{s}"] > threshold for s in STRATEGIES)
    return [f"table2: average fitness {table['average'].iloc[0]:.0f} after iteration 1, "
            f"{last['average']:.0f} after iteration {int(last['iteration'])} "
            f"({last['average'] / table['average'].iloc[0]:.0%} of the first; paper 96%); "
            f"every strategy above the {threshold:.0f}-step threshold at the end: {kept}"]
