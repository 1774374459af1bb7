"""Paper §5.3–5.4: collision avoidance among dynamic vehicles — learning curves per traffic
strategy (Fig. 11), deployment on unseen strategies (Table 1, Fig. 12), and incremental
evolution over strategies (Table 2).

Two families of strategies run the same experiments: the arena's kinematic strategies
(``scenarios/arena_strategy1..4``, into the reproduce folder) and SUMO traffic on SUMO networks
(``scenarios/sumo_strategy1..4``, into its ``sumo/`` subfolder)."""

from __future__ import annotations

from dataclasses import dataclass, replace
from functools import cache
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd

from enn_traffic import keys
from enn_traffic.deploy import EVALUATION_KEY
from enn_traffic.evolution.backends import MeanOverWorlds
from enn_traffic.evolution.ga import GAState
from enn_traffic.experiments.common import distinct, run_all, run_or_reuse
from enn_traffic.io import write_csv
from enn_traffic.report.plots import draw_paths, learning_curves, save_figure
from enn_traffic.scenario import Scenario, load_scenario
from enn_traffic.shipped import shipped_scenario
from enn_traffic.sim.world import EpisodeResults, World
from enn_traffic.worlds import make_world

STRATEGIES = [1, 2, 3, 4]
# Candidates are chosen on validation traffic, never on the test traffic of Tables 1 and 2.
VALIDATION_KEY = keys.VALIDATION.start
# Table 2 (§5.4.1): a strategy is added once the fitness on every strategy included so far
# exceeds 80% of the accepted fitness, judged on validation traffic for the TOP_CANDIDATES
# fittest of a generation, since a generation's best fitness alone is mostly luck: a candidate
# that passes on test_episodes situations must pass again on recheck_episodes other ones
# (ACCEPTANCE_KEY) by its mean less ACCEPTANCE_ERRORS standard errors, so that a candidate just
# under the threshold seldom passes by the luck of one of the many checks a run makes.
TOP_CANDIDATES = 5
ACCEPTANCE_KEY = keys.ACCEPTANCE.start
ACCEPTANCE_ERRORS = 2.0
# The best of a few hundred candidates on test_episodes situations is partly luck too: the
# RECHECKED best are scored again on recheck_episodes validation situations before the choice.
RECHECKED = 10


@dataclass(frozen=True)
class Family:
    """A set of four traffic strategies (scenarios ``PREFIX1..4``) and the experiment settings
    that go with it."""

    prefix: str
    folder: str  # subfolder of the reproduce folder ("" for the top)
    seeds: tuple[int, ...]
    test_episodes: int  # Fig. 11's test curves, and the first look at candidates
    recheck_episodes: int
    table_episodes: int  # the test situations of each entry of Tables 1 and 2
    accepted_fitness: float
    incremental_max_generations: int
    # Table 2's hidden layers (None: the scenarios' own): its one controller must hold every
    # strategy's skill, each of Table 1's only one (docs/results.md, "Why Table 2 evolves a
    # wider network")
    incremental_hidden: tuple[int, ...] | None = None
    incremental_seeds: tuple[int, ...] = (1,)  # Table 2's evolutions, one per GA seed
    hidden: tuple[int, ...] | None = None  # every scenario's hidden layers, when given
    quick: tuple = (("population_size", 40), ("generations", 12), ("elite_count", 4))
    # --quick: the first seeds, fewer test situations, and scenario overrides (section, items)
    quick_seeds: int = 2
    quick_test_episodes: int = 10
    quick_scenario: tuple = ()
    quick_mode: bool = False

    def name(self, strategy: int) -> str:
        return f"{self.prefix}{strategy}"

    def settings(self, quick: bool) -> Family:
        """This family as ``--quick`` runs it, or unchanged."""
        if not quick or self.quick_mode:
            return self
        return replace(self, seeds=self.seeds[: self.quick_seeds],
                       incremental_seeds=self.incremental_seeds[: self.quick_seeds],
                       test_episodes=self.quick_test_episodes,
                       recheck_episodes=self.quick_test_episodes,
                       table_episodes=self.quick_test_episodes, quick_mode=True)

    def incremental(self) -> Family:
        """This family as Table 2 runs it: with the incremental network."""
        return replace(self, hidden=self.incremental_hidden)

    def overrides(self) -> dict:
        overrides = ({section: dict(items) for section, items in self.quick_scenario}
                     if self.quick_mode else {})
        if self.hidden is not None:
            overrides["network"] = {"hidden": list(self.hidden)}
        return overrides

    def scenario(self, strategy: int) -> Scenario:
        """A strategy's scenario, with the quick overrides in quick mode and the family's
        hidden layers if it sets them."""
        sc, overrides = shipped_scenario(self.name(strategy)), self.overrides()
        return sc.with_overrides(**overrides) if overrides else sc

    @property
    def threshold(self) -> float:
        """Table 2's acceptance threshold: 80% of the accepted fitness (§5.4.1)."""
        return 0.8 * self.accepted_fitness

    def ga(self) -> dict:
        """GA overrides: the small quick settings in quick mode."""
        return dict(self.quick) if self.quick_mode else {}


ARENA = Family("arena_strategy", "", (1, 2, 3, 4), test_episodes=40, recheck_episodes=200,
               table_episodes=200, accepted_fitness=750.0, incremental_max_generations=150,
               incremental_hidden=(6,), incremental_seeds=(1, 2, 3, 4))
SUMO = Family("sumo_strategy", "sumo", (1, 2), test_episodes=10, recheck_episodes=30,
              table_episodes=10, accepted_fitness=2000.0, incremental_max_generations=20,
              quick=(("population_size", 40), ("generations", 6), ("elite_count", 4)),
              quick_seeds=1, quick_test_episodes=3,
              quick_scenario=(("episode", (("max_steps", 1000),)),
                              ("traffic", (("warmup_s", 20.0),))))


def _run_dir(family: Family, out: Path, strategy: int, seed: int) -> Path:
    """Where a strategy's run of one seed lives in the (family's) output folder."""
    return out / "runs" / family.name(strategy) / f"seed{seed}"


def _family_runs(family: Family, out: Path, progress: bool) -> dict[int, dict[int, pd.DataFrame]]:
    """Every strategy's runs, one per seed (all submitted at once, so on Ray they run side by
    side): ``{strategy: {seed: generations table}}``."""
    jobs = {}
    for strategy in STRATEGIES:
        base = family.scenario(strategy)
        for seed in family.seeds:
            jobs[strategy, seed] = (base.with_overrides(seed=seed, ga=family.ga()),
                                    _run_dir(family, out, strategy, seed))
    tables = run_all(jobs, progress)
    return {strategy: {seed: tables[strategy, seed] for seed in family.seeds}
            for strategy in STRATEGIES}


def _test_world(family: Family, strategy: int, episodes: int | None = None) -> World:
    """The world of a strategy with ``episodes`` traffic situations (``test_episodes`` unless
    given), built once for each count."""
    return _world(family, strategy, episodes or family.test_episodes)


@cache
def _world(family: Family, strategy: int, episodes: int) -> World:
    sc = family.scenario(strategy)
    return make_world(sc.with_overrides(traffic={"episodes": episodes}))


def _results(family: Family, candidates: np.ndarray, strategy: int, key: int,
             episodes: int | None = None) -> EpisodeResults:
    """Each candidate driven in the episodes (``test_episodes`` unless given) drawn from
    ``key``."""
    return _test_world(family, strategy, episodes).evaluate(np.atleast_2d(candidates), key)


def _mean_fitness(family: Family, candidates: np.ndarray, strategy: int, key: int,
                  episodes: int | None = None) -> np.ndarray:
    """Mean fitness of each candidate over the episodes (``test_episodes`` unless given)
    drawn from ``key``."""
    return _results(family, candidates, strategy, key, episodes).fitness


def _lower_bound(family: Family, candidates: np.ndarray, strategy: int, key: int,
                 episodes: int) -> np.ndarray:
    """Each candidate's mean fitness over ``episodes`` situations drawn from ``key``, less
    ``ACCEPTANCE_ERRORS`` standard errors of that mean."""
    results = _results(family, candidates, strategy, key, episodes)
    fitness = EpisodeResults.lifetime_fitness(results.steps, results.outcome)
    error = fitness.std(axis=1, ddof=1) / np.sqrt(episodes)
    return fitness.mean(axis=1) - ACCEPTANCE_ERRORS * error


def _candidates(run_dir: Path) -> np.ndarray:
    """A run's controllers to choose from: every generation's best chromosome (the run's best
    alone for a run that kept none) and the elites at the head of its final population, each
    once."""
    state = GAState.load(run_dir / "checkpoint.npz")
    elites = load_scenario(run_dir / "scenario.toml").ga.elite_count
    champions = state.champions
    if champions is None:  # a run from before runs kept them
        champions = (state.population[:0] if state.best_chromosome is None
                     else state.best_chromosome[None, :])
    return distinct(np.concatenate([champions, state.population[: max(elites, 1)]]))


def _validation(family: Family, candidates: np.ndarray, strategies: list[int],
                episodes: int | None = None) -> np.ndarray:
    """Mean fitness (candidates, strategies) on validation traffic."""
    return np.stack([_mean_fitness(family, candidates, s, VALIDATION_KEY, episodes)
                     for s in strategies], axis=1)


def _pick(family: Family, candidates: np.ndarray, strategies: list[int]) -> np.ndarray:
    """The candidate whose worst strategy does best on validation traffic, as Table 2's
    acceptance asks of every included strategy (§5.4.1): every candidate on
    ``test_episodes`` situations, then the ``RECHECKED`` best on ``recheck_episodes``."""
    return _scored_pick(family, candidates, strategies)[0]


def _scored_pick(family: Family, candidates: np.ndarray, strategies: list[int]
                 ) -> tuple[np.ndarray, float]:
    """:func:`_pick`, and the picked candidate's worst strategy on the recheck."""
    worst = _validation(family, candidates, strategies).min(axis=1)
    best = candidates[np.argsort(-worst, kind="stable")[:RECHECKED]]
    worst = _validation(family, best, strategies, family.recheck_episodes).min(axis=1)
    return best[int(np.argmax(worst))], float(worst.max())


def _accepts(family: Family, candidates: np.ndarray, strategies: list[int],
             threshold: float) -> bool:
    """Table 2's acceptance (§5.4.1): one of ``candidates`` reaches ``threshold`` on every
    strategy in ``test_episodes`` validation situations, and its mean less
    ``ACCEPTANCE_ERRORS`` standard errors does so in ``recheck_episodes`` others."""
    worst = _validation(family, candidates, strategies).min(axis=1)
    passing = candidates[worst >= threshold]
    if len(passing) == 0:
        return False
    bounds = np.stack([_lower_bound(family, passing, s, ACCEPTANCE_KEY, family.recheck_episodes)
                       for s in strategies], axis=1)
    return bool((bounds.min(axis=1) >= threshold).any())


def _test_fitness(family: Family, chromosome: np.ndarray, strategy: int) -> float:
    """Mean fitness over the ``table_episodes`` test situations of a strategy's traffic."""
    return float(_mean_fitness(family, chromosome, strategy, EVALUATION_KEY,
                               family.table_episodes)[0])


def _title(family: Family, strategy: int) -> str:
    sc = family.scenario(strategy)
    kind = sc.traffic.strategy if family is ARENA else sc.description.rstrip(".")
    return f"strategy {strategy}: {kind}"


def _held_out(family: Family, out: Path, strategy: int, seed: int) -> np.ndarray | None:
    """Each generation's best chromosome of a run, scored again on the strategy's test traffic
    (None for a run that kept no champions): what the run learned, apart from the luck of its
    own traffic, which inflates a generation's best training fitness."""
    champions = GAState.load(_run_dir(family, out, strategy, seed) / "checkpoint.npz").champions
    return None if champions is None else _mean_fitness(family, champions, strategy,
                                                         EVALUATION_KEY)


def fig11(out: Path, quick: bool = False, progress: bool = True,
          family: Family = ARENA) -> list[str]:
    """Learning curves, one run per seed and strategy, one panel per strategy: each
    generation's best training fitness (solid) and the same chromosome on test traffic
    (dashed)."""
    family = family.settings(quick)
    out = out / family.folder
    figure, axes = plt.subplots(2, 2, figsize=(10, 7), sharex=True)
    rows = []
    family_runs = _family_runs(family, out, progress)
    for strategy, ax in zip(STRATEGIES, axes.ravel(), strict=True):
        runs = family_runs[strategy]
        learning_curves({f"seed {s}": t for s, t in runs.items()}, None, axes=ax,
                        title=_title(family, strategy))
        for index, (seed, table) in enumerate(runs.items()):
            best, mean = table["best_fitness"], table["mean_fitness"]
            held_out = _held_out(family, out, strategy, seed)
            if held_out is not None:
                ax.plot(table["generation"], held_out, color=f"C{index}", ls="--", lw=0.9)
            else:
                held_out = np.full(len(table), np.nan)
            rows.append({
                "strategy": strategy, "seed": seed, "generations": len(table),
                "first_best": best.iloc[0], "last_best": best.iloc[-1],
                "last5_mean_best": best.tail(5).mean(), "max_best": best.max(),
                "rise": best.tail(5).mean() / max(best.iloc[0], 1.0),
                "first_mean": mean.iloc[0], "last5_mean_mean": mean.tail(5).mean(),
                "mean_rise": mean.tail(5).mean() / max(mean.iloc[0], 1.0),
                "first_held_out": held_out[0], "last5_mean_held_out": held_out[-5:].mean(),
                "held_out_rise": held_out[-5:].mean() / max(held_out[0], 1.0),
            })  # fmt: skip
    runs_each = len(family.seeds)
    figure.suptitle(f"Fig. 11 ({family.prefix}1-4): the learner among traffic, "
                    f"{runs_each} runs per strategy\nsolid: each generation's best fitness; "
                    f"dashed: the same chromosome on {family.test_episodes} test situations")
    figure.tight_layout()
    save_figure(figure, out / "fig11.png")
    table = pd.DataFrame(rows)
    write_csv(out / "fig11.csv", table)
    rise = table.groupby("strategy")[["rise", "mean_rise", "held_out_rise"]].median()
    label = f"{family.folder}/fig11" if family.folder else "fig11"
    return [f"{label}: best fitness, mean of the last 5 generations over the first generation's "
            "(median of the runs): "
            + ", ".join(f"strategy {s}: {r.rise:.1f}x" for s, r in rise.iterrows())
            + "; population mean fitness: "
            + ", ".join(f"{r.mean_rise:.1f}x" for _, r in rise.iterrows())
            + "; each generation's best on test traffic: "
            + ", ".join(f"{r.held_out_rise:.1f}x" for _, r in rise.iterrows())]


def _trained_controllers(family: Family, out: Path, progress: bool) -> dict[int, np.ndarray]:
    """Per strategy: the best of its runs' candidates, judged on validation traffic of that
    same strategy."""
    candidates = _evolved_candidates(family, out, progress)
    return {strategy: _pick(family, candidates[strategy], [strategy])
            for strategy in STRATEGIES}


def _evolved_candidates(family: Family, out: Path, progress: bool) -> dict[int, np.ndarray]:
    """Per strategy: every run's candidates (:func:`_candidates`; the runs done first if need
    be)."""
    _family_runs(family, out, progress)
    return {strategy: np.concatenate([
                _candidates(_run_dir(family, out, strategy, seed))
                for seed in family.seeds])
            for strategy in STRATEGIES}  # fmt: skip


def evolved_candidates(out: Path, quick: bool, progress: bool, family: Family = ARENA
                       ) -> dict[int, np.ndarray]:
    """Per strategy: the controllers individual learning evolved on it (§5.3), from which
    Table 1 and §5.5 choose."""
    family = family.settings(quick)
    return _evolved_candidates(family, out / family.folder, progress)


def final_population(family: Family, out: Path, strategy: int, chosen: np.ndarray,
                     quick: bool) -> np.ndarray:
    """The final population of the run that produced ``chosen``."""
    family = family.settings(quick)
    out = out / family.folder
    for seed in family.seeds:
        run_dir = _run_dir(family, out, strategy, seed)
        if any(np.array_equal(row, chosen) for row in _candidates(run_dir)):
            return GAState.load(run_dir / "checkpoint.npz").population
    raise ValueError(f"no run of {family.name(strategy)} produced the chosen controller")


def trained_controllers(out: Path, quick: bool, progress: bool, family: Family = ARENA
                        ) -> dict[int, np.ndarray]:
    """Per strategy: the controller Table 1 deploys (trained on that strategy alone)."""
    family = family.settings(quick)
    return _trained_controllers(family, out / family.folder, progress)


def _draw_specialists(family: Family, controllers: dict[int, np.ndarray], path: Path,
                      steps: int = 400) -> None:
    """Table 1 as paths: each strategy's chosen controller (row) among each strategy's traffic
    (column), the first test episode."""
    size = len(STRATEGIES)
    figure, axes = plt.subplots(size, size, figsize=(2.6 * size, 2.75 * size))
    for column, deployed in enumerate(STRATEGIES):
        world = _test_world(family, deployed)
        for row, trained in enumerate(STRATEGIES):
            ax = axes[row, column]
            poses, _ = world.trace(controllers[trained], EVALUATION_KEY, max_steps=steps)
            traffic = [poses[:, v] for v in range(1, poses.shape[1])]
            draw_paths(ax, world.track.walls, [*traffic, poses[:, 0]],
                       colors=["0.65"] * len(traffic) + ["C3"])
            ax.set_xticks([])
            ax.set_yticks([])
            ax.set_title(f"trained {trained}, among {deployed}: {len(poses) - 1} steps",
                         fontsize=8)
    figure.suptitle(f"Table 1 as paths: each strategy's controller (red, by row) among each "
                    f"strategy's traffic (grey, by column),\nfirst {steps} steps of a test "
                    "episode (x: where a vehicle's path ends)")
    figure.tight_layout()
    save_figure(figure, path)


def table1(out: Path, quick: bool = False, progress: bool = True,
           family: Family = ARENA) -> list[str]:
    """Train on each strategy, deploy on each (Table 1), and the colour map (Fig. 12)."""
    family = family.settings(quick)
    out = out / family.folder
    controllers = _trained_controllers(family, out, progress)
    matrix = np.array([[_test_fitness(family, controllers[trained], deployed)
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
    _draw_specialists(family, controllers,
                      out / ("arena_paths.png" if family is ARENA else "paths.png"))
    diagonal = np.diag(matrix)
    off = matrix[~np.eye(4, dtype=bool)]
    rows_ok = sum(diagonal[i] > np.delete(matrix[i], i).max() for i in range(4))
    label = f"{family.folder}/table1" if family.folder else "table1"
    return [f"{label}: mean diagonal {diagonal.mean():.0f}, mean off-diagonal {off.mean():.0f} "
            f"(ratio {diagonal.mean() / off.mean():.2f}; paper 4.9); diagonal above the rest "
            f"of its row in {rows_ok} of 4 rows (paper: 4 of 4)"]


def _incremental_chain(family: Family, out: Path, seed: int, progress: bool
                       ) -> tuple[list[dict], float]:
    """One incremental evolution (§5.4.1) from GA seed ``seed`` into ``out``: a row of test
    fitness per iteration, and the worst strategy of the last iteration's controller on
    validation traffic."""
    threshold = family.threshold
    base = family.scenario(1)
    population, rows = None, []
    for iteration in range(1, len(STRATEGIES) + 1):
        ga = {"generations": family.incremental_max_generations, **family.ga()}
        # the acceptance rule is part of the run's settings: a run stopped by another is redone
        rule = (f"Incremental evolution (§5.4.1), iteration {iteration}: stops when one of the "
                f"{TOP_CANDIDATES} fittest reaches {threshold:g} steps on every included "
                f"strategy in {family.test_episodes} validation situations, and by its mean "
                f"less {ACCEPTANCE_ERRORS:g} standard errors in {family.recheck_episodes} "
                "others.")
        sc = base.with_overrides(name=f"incremental_{iteration}", description=rule, seed=seed,
                                 ga=ga)
        included = STRATEGIES[:iteration]
        scenarios = [family.scenario(s) for s in included]
        worlds = [make_world(sc) for sc in scenarios]

        def accepted(population, fitness, included=included):
            fittest = population[np.argsort(-fitness, kind="stable")[:TOP_CANDIDATES]]
            return _accepts(family, fittest, included, threshold)

        run_dir = out / f"iteration{iteration}"
        table = run_or_reuse(sc, run_dir, progress, evaluator=MeanOverWorlds(worlds),
                             initial_population=population, stop=accepted, others=scenarios)
        state = GAState.load(run_dir / "checkpoint.npz")
        population = state.population
        chosen, worst = _scored_pick(family, _candidates(run_dir), included)
        row = {"seed": seed, "iteration": iteration, "generations": len(table),
               "reached_threshold": bool(state.extra.get("target_reached", False))}
        for strategy in STRATEGIES:
            row[f"strategy_{strategy}"] = (_test_fitness(family, chosen, strategy)
                                           if strategy in included else np.nan)
        row["average"] = float(np.nanmean([row[f"strategy_{s}"] for s in included]))
        rows.append(row)
    return rows, worst


def table2(out: Path, quick: bool = False, progress: bool = True,
           family: Family = ARENA) -> list[str]:
    """Incremental evolution: add a strategy each time the fitness passes 80% of the accepted
    fitness; the fitness is averaged over the strategies included so far (§5.4.1). One
    evolution per seed of ``incremental_seeds``; Table 2 is the one whose last controller's
    worst strategy does best on validation traffic, as Table 1 chooses among its seeds' runs."""
    family = family.settings(quick).incremental()
    out = out / family.folder
    threshold = family.threshold
    chains = {seed: _incremental_chain(family, out / "runs" / "incremental" / f"seed{seed}",
                                       seed, progress)
              for seed in family.incremental_seeds}
    seed = max(chains, key=lambda s: chains[s][1])  # the first of equals, as argmax
    every = pd.DataFrame([row for rows, _ in chains.values() for row in rows])
    write_csv(out / "table2_runs.csv", every.round(1))
    table = every[every["seed"] == seed].drop(columns="seed").reset_index(drop=True)
    write_csv(out / "table2.csv", table.round(1))
    last = table.iloc[-1]
    kept = all(last[f"strategy_{s}"] > threshold for s in STRATEGIES)
    ends = every.groupby("seed").last()[[f"strategy_{s}" for s in STRATEGIES]].min(axis=1)
    label = f"{family.folder}/table2" if family.folder else "table2"
    return [f"{label}: average fitness {table['average'].iloc[0]:.0f} after iteration 1, "
            f"{last['average']:.0f} after iteration {int(last['iteration'])} "
            f"({last['average'] / table['average'].iloc[0]:.0%} of the first; paper 96%); "
            f"every strategy above the {threshold:.0f}-step threshold at the end: {kept} "
            f"(seed {seed} of {len(chains)}, chosen on validation traffic; each seed's worst "
            "strategy at the end: " + ", ".join(f"{v:.0f}" for v in ends) + ")"]


def replay_against_closed_loop(out: Path, quick: bool = False, progress: bool = True
                               ) -> list[str]:
    """Each SUMO strategy's Table 1 controller (trained on replayed traffic) on the same test
    situations with the traffic replayed and in closed loop: lifetimes side by side."""
    controllers = trained_controllers(out, quick, progress, SUMO)
    rows = []
    for strategy in STRATEGIES:
        test = _test_world(SUMO.settings(quick), strategy).scenario
        lifetimes = {}
        for mode in ("replay", "closed-loop"):
            world = make_world(test.with_overrides(traffic={"mode": mode}))
            lifetimes[mode] = world.evaluate(controllers[strategy][None, :], EVALUATION_KEY)
        for episode in range(test.traffic.episodes):
            rows.append({"strategy": strategy, "episode": episode,
                         "replay_steps": int(lifetimes["replay"].steps[0, episode]),
                         "closed_loop_steps": int(lifetimes["closed-loop"].steps[0, episode])})
    table = pd.DataFrame(rows)
    write_csv(out / SUMO.folder / "closed_loop.csv", table)
    means = table.groupby("strategy")[["replay_steps", "closed_loop_steps"]].mean()
    return ["sumo/closed_loop: mean lifetime of each strategy's controller, replayed vs closed "
            "loop: " + ", ".join(f"strategy {s}: {r.replay_steps:.0f} vs {r.closed_loop_steps:.0f}"
                                 for s, r in means.iterrows())]


def sumo(out: Path, quick: bool = False, progress: bool = True) -> list[str]:
    """Fig. 11, Table 1 and Table 2 over the SUMO traffic strategies, and the replayed against
    the closed-loop lifetimes, into ``out/sumo/``."""
    return [*fig11(out, quick, progress, SUMO), *table1(out, quick, progress, SUMO),
            *table2(out, quick, progress, SUMO),
            *replay_against_closed_loop(out, quick, progress)]
