"""Paper §5.5: simultaneous collision avoidance — every vehicle of the arena driven by an
evolved network, spreading what individual learning (§5.3) found to all of them.

For each arena strategy and each of the ``LEARNING.situations`` traffic situations (the 8
start poses of ``scenarios/arena_strategyN``, headings drawn per situation), every arm drives
from the start poses in spans of ``SECONDS`` (100 s, the paper's):

- initial behaviour: all 8 vehicles driven by the strategy's own drivers;
- Table 3 (§5.5.1, broadcasting the winning chromosome): all 8 driven by the winning
  chromosome — of the controllers individual learning evolved on the strategy (every
  generation's best of every run, and the final elites), the one that loses fewest lives
  (collisions and spins) when it drives all 8 vehicles, judged on ``VALIDATION_SITUATIONS``
  situations apart from the measured ones. Table 3 compares the first span. Beside it, the
  paper's way (``paper_winner``): the fittest chromosome individual learning found by its own
  GA fitness (the best of the strategy's runs), with no ranking in the crowd;
- Table 4 (§5.5.2, broadcasting the evolved population): every vehicle starts from a copy of the
  evolved population (the candidates, fewest broadcast lives lost first, then the rest of the
  winner's run's final population) and all learn at once, each its own GA a chromosome per
  life, breeding when it has tried its population, with the best chromosomes of all vehicles
  as its elites (reference §7.4). A life that reaches the cap ends its chromosome's trial
  without a respawn. Learning lasts ``LEARNING.learning_s``, long enough that every learner
  breeds several generations (chosen on the validation situations, docs/results.md); then
  each vehicle drives "a customized solution": the fittest chromosome of its last whole
  generation (the authors' rule, :meth:`~enn_traffic.learning.online.VehicleGA.evolved`),
  measured over the next span. The initial drivers and the winner drive that long too, so
  Table 4 sets all arms side by side over the same span, paired by situation; the named
  alternative ``reranked`` (each vehicle the chromosome that lost fewest lives per step in
  its own lives) drives from the same state after learning.

The metric is the scenario's ``[crowd] counting`` (:meth:`enn_traffic.sim.crowd.CrowdRun.rate`):
by default responsible collisions per vehicle-second; lives lost (collisions and spins) of all
vehicles together per second is the paper's unit (:mod:`enn_traffic.experiments.regime`).
Evolved drivers are held to §5.3's spin rule throughout: rotating in place ends a life (the
vehicle respawns); their spins per second are recorded beside the collisions.

Written beside the tables: ``table4_learners.csv`` (per learner: generations bred, lives lost,
chromosomes tried), ``table4_learning.csv`` and its plot (the collision rate of every arm in
each span of the learning), and under ``controllers/`` each strategy's winner
(``table3/strategyS.npz``), its evolved population (``table4/strategyS_evolved.npz``) and each
vehicle's controller after learning in the first situation (``table4/strategyS_vehicleV.npz``):
with them, that situation's every span can be driven again.
"""

from __future__ import annotations

import time
from collections.abc import Mapping
from pathlib import Path

import numpy as np
import pandas as pd
from tqdm import tqdm

from enn_traffic.config import Scenario
from enn_traffic.config.shipped import shipped_scenario
from enn_traffic.config.traffic import STRATEGIES
from enn_traffic.core import keys
from enn_traffic.core.io import write_csv
from enn_traffic.core.progress import slow_step, terminal
from enn_traffic.experiments.choosing import evolved_candidates, final_population
from enn_traffic.experiments.common import distinct, save_arrays, save_controller
from enn_traffic.experiments.crowds.settings import CrowdSettings
from enn_traffic.experiments.crowds.stats import (
    ARMS,
    REDUCTIONS,
    Measured,
    SituationResult,
    curve_facts,
    learning_curve,
    learning_ends,
    mean_reduction,
    paired_by_strategy,
    rates_table,
    reduction_interval,
    strategy_means,
    table4_comparisons,
    trend_facts,
)
from enn_traffic.experiments.families import ARENA, run_dir
from enn_traffic.experiments.study import Study
from enn_traffic.learning import ga
from enn_traffic.learning.online import Evidence, OnlineLearning, VehicleGA
from enn_traffic.report.paper import PAPER_REDUCTION
from enn_traffic.runs.controller import Controller
from enn_traffic.sim.arena import ArenaWorld
from enn_traffic.sim.crowd import Crowd, CrowdRun
from enn_traffic.sim.strategies import NETWORK
from enn_traffic.sumo.fresh import fresh_shares

SECONDS = 100.0  # the paper's training time; each measured span and learning-curve window


SITUATION_KEY = keys.ARENA_CROWD_TEST.start  # the situations whose rates are reported


VALIDATION_KEY = keys.CROWD_CHOICE.start  # the situations that choose the winner


VALIDATION_SITUATIONS = 20


DRAWN_SECONDS = 20.0


# Table 3's paper-way winner against ours: 90% for the four strategies together (Bonferroni)
PAPER_WAY_LEVEL = 1 - 0.1 / 4


# The arena's crowds: learning long enough that every learner breeds at least 3 generations,
# with a life cap of 300 steps, chosen on the crowd validation situations
# (table4_validation_learners.csv; docs/results.md, "All vehicles at once"); each vehicle
# copies the whole evolved population of the arena's GA (its [ga]: 200 rows, 20 elites).
LEARNING = CrowdSettings(learning_s=15000.0, window_s=SECONDS, life_cap_steps=300,
                         population_size=200, elite_count=20, situations=20,
                         validation_situations=2,
                         quick={"learning_s": 200.0, "situations": 2})


def situation_crowd(world: ArenaWorld, situation: int, kinds=None, key: int = SITUATION_KEY
           ) -> tuple[Crowd, np.ndarray]:
    """The arena of one traffic situation: 8 start poses; ``kinds`` default to the strategy's
    own drivers; and the drivers' random genes (random-network strategy)."""
    chosen = world.situations(key + situation)[0]
    strategy = STRATEGIES[world.scenario.traffic.strategy_list[0]]
    kinds = np.full(world.vehicles, strategy) if kinds is None else kinds
    return Crowd(world, chosen.start, kinds, int(chosen.seed)), chosen.traffic_genes.copy()


def _broadcast(world: ArenaWorld, genes: np.ndarray, situation: int, key: int = SITUATION_KEY,
               periods: int = 1) -> list[CrowdRun]:
    """``periods`` spans of ``SECONDS``, one after another, of one situation with ``genes``
    (world layout) driving every vehicle, held to the spin rule."""
    arena, _ = situation_crowd(world, situation, np.full(world.vehicles, NETWORK), key)
    return [arena.run(SECONDS, np.tile(genes, (world.vehicles, 1)), check_spins=True)
            for _ in range(periods)]


def _ranked(world: ArenaWorld, candidates: np.ndarray) -> np.ndarray:
    """The candidates, fewest lives lost per step (collisions and spins) first when each
    drives every vehicle on validation situations: the first is §5.5.1's winning
    chromosome. A share of the candidates is driven in each of several fresh processes
    (:func:`~enn_traffic.sumo.fresh.fresh_shares`); every broadcast is the same wherever it
    runs."""
    evidence = Evidence()
    source = world.spec.in_source_layout(candidates)
    with slow_step(f"ranking {world.scenario.name}: {len(source)} candidates, each driving "
                   f"every vehicle on {VALIDATION_SITUATIONS} situations"):
        lost = fresh_shares(lives_lost, source, world.scenario)
    for genes, runs in zip(source, lost, strict=True):
        for vehicle_steps, lives in runs:
            evidence.record(genes, vehicle_steps, lives)
    rates = [evidence.loss_rate(genes.tobytes()) for genes in source]
    return candidates[np.argsort(rates, kind="stable")]


def lives_lost(scenario: Scenario, source: np.ndarray) -> list[list[tuple[int, int]]]:
    """Each candidate (source layout) driving every vehicle of each validation situation:
    (vehicle-steps, lives lost to collisions and spins) per situation; what :func:`_ranked`
    runs in a fresh process."""
    world = ArenaWorld(scenario)
    return [[(run.vehicle_steps, int(run.collisions.sum() + run.spins.sum()))
             for run in (_broadcast(world, genes, situation, VALIDATION_KEY)[0]
                         for situation in range(VALIDATION_SITUATIONS))]
            for genes in source]


def _evolved_population(ranked: np.ndarray, run_population: np.ndarray, size: int
                        ) -> np.ndarray:
    """§5.5.2's evolved population: the ranked candidates, then the rest of the winner's run's
    final population, ``size`` distinct chromosomes at most."""
    return distinct(np.concatenate([ranked, run_population]))[:size]


def learn_together(world: ArenaWorld, situation: int, winner: np.ndarray, evolved: np.ndarray,
                   learning: CrowdSettings, key: int = SITUATION_KEY
                   ) -> tuple[Crowd, OnlineLearning, list[CrowdRun]]:
    """Every vehicle of one situation learning from its own copy of ``evolved`` for
    ``learning.learning_s``, span by span: the crowd after it, the learning and each span's run.
    ``winner`` (G,) and ``evolved`` (N, G) in the source layout."""
    sc = world.scenario
    arena, _ = situation_crowd(world, situation, np.full(world.vehicles, NETWORK), key)
    learners = [VehicleGA(evolved.copy(), np.random.default_rng([sc.seed, situation, v]))
                for v in range(world.vehicles)]
    if learning.start_population == "random":  # the authors' start (reference §7.1)
        for learner in learners:
            learner.population = world.spec.in_source_layout(ga.initial_population(
                learner.rng, sc.ga.population_size, world.spec.chromosome_length,
                sc.ga.init_range))
            learner.fitness = np.zeros(len(learner.population))
    online = OnlineLearning(learners, sc.ga, share_elites=True,
                            elite_count=sc.ga.elite_count, life_cap=learning.life_cap_steps,
                            finish_steps=learning.finish_steps)
    genes = np.tile(winner, (world.vehicles, 1))
    spans = round(learning.learning_s / SECONDS)
    return arena, online, [arena.run(SECONDS, genes, online) for _ in range(spans)]


def situation_rates(world: ArenaWorld, situation: int, winner: np.ndarray, evolved: np.ndarray,
                    learning: CrowdSettings = LEARNING, key: int = SITUATION_KEY
                    ) -> SituationResult:
    """One situation's every arm. ``winner`` (G,) and ``evolved`` (N, G) in the source
    layout."""
    spans = round(learning.learning_s / SECONDS)
    counting = world.scenario.crowd.counting
    arena, genes = situation_crowd(world, situation, key=key)
    initial = [arena.run(SECONDS, genes) for _ in range(spans + 1)]
    broadcast = _broadcast(world, winner, situation, key, periods=spans + 1)
    arena, online, learnt = learn_together(world, situation, winner, evolved, learning, key)
    reranked = arena.fork().run(SECONDS, online.own_controllers(), check_spins=True)
    own = online.evolved_controllers()
    after = arena.run(SECONDS, own.copy(), check_spins=True)
    rates = {"initial": initial[0].rate(counting), "winner": broadcast[0].rate(counting),
             "winner_spins": broadcast[0].spin_rate,
             "learning": float(np.mean([run.rate(counting) for run in learnt])),
             "initial_after": initial[-1].rate(counting),
             "winner_after": broadcast[-1].rate(counting),
             "population": after.rate(counting), "population_spins": after.spin_rate,
             "reranked": reranked.rate(counting), "reranked_spins": reranked.spin_rate}
    windows = [{"window_start_s": span * SECONDS, "learning": learnt[span].rate(counting),
                "initial_drivers": initial[span].rate(counting),
                "winner_driving_on": broadcast[span].rate(counting)}
               for span in range(spans)]
    return SituationResult(rates, windows, online.learner_rows(),
                           world.spec.from_source_layout(own),
                           (initial[0].trace, broadcast[0].trace, after.trace, world.track.walls))


def measure_strategy(world: ArenaWorld, strategy: int, winner: np.ndarray,
                     population: np.ndarray, learning: CrowdSettings, progress: bool = False
                     ) -> tuple[list[dict], list[dict], list[dict], SituationResult]:
    """One strategy's rows (situations, windows, learners) and its first situation."""
    winner_genes = world.spec.in_source_layout(winner)[0]
    evolved = world.spec.in_source_layout(population)
    rows, windows, learners, first = [], [], [], None
    for situation in tqdm(range(learning.situations), desc=f"arena_strategy{strategy} crowds",
                          unit="situation", disable=not progress, leave=False,
                          file=terminal()):
        result = situation_rates(world, situation, winner_genes, evolved, learning)
        label = {"strategy": strategy, "situation": situation}
        rows.append(label | result.rates)
        windows.extend(label | window for window in result.windows)
        learners.extend(label | learner for learner in result.learners)
        first = first or result
    return rows, windows, learners, first


def validation_learners(inputs: dict[int, tuple[np.ndarray, np.ndarray]],
                        learning: CrowdSettings, situations: int = 2) -> pd.DataFrame:
    """The learners' counts in ``situations`` crowd validation situations per strategy: what
    chose ``learning``'s time and cap (every learner breeds 3 generations or more)."""
    rows = []
    for strategy, (winner, population) in inputs.items():
        world = ArenaWorld(shipped_scenario(ARENA.name(strategy)))
        for situation in range(situations):
            _, online, _ = learn_together(world, situation,
                                          world.spec.in_source_layout(winner)[0],
                                          world.spec.in_source_layout(population), learning,
                                          VALIDATION_KEY)
            rows += [{"strategy": strategy, "situation": situation} | learner
                     for learner in online.learner_rows()]
    return pd.DataFrame(rows)


def measure(out: Path, inputs: dict[int, tuple[np.ndarray, np.ndarray]],
            learning: CrowdSettings, progress: bool = False,
            paper_winners: Mapping[int, np.ndarray] | None = None) -> Measured:
    """Tables 3–4's every strategy from its winner and evolved population (``inputs``:
    strategy -> (winner, population), world layout), written under ``out``: the situations,
    the learning windows, the learners and the first situation's controllers and paths; with
    ``paper_winners`` (strategy -> chromosome, world layout), each situation's first span
    with the paper's winner driving every vehicle too (column ``paper_winner``)."""
    write_csv(out / "table4_validation_learners.csv", validation_learners(inputs, learning))
    rows, windows, learners, paths, wall = [], [], [], {}, {}
    for strategy, (winner, population) in inputs.items():
        world = ArenaWorld(shipped_scenario(ARENA.name(strategy)))
        started = time.perf_counter()
        each, spans, counts, first = measure_strategy(world, strategy, winner, population,
                                                      learning, progress)
        if paper_winners is not None:
            genes = world.spec.in_source_layout(paper_winners[strategy])[0]
            for row in each:
                row["paper_winner"] = _broadcast(world, genes, row["situation"])[0].collision_rate
        wall[strategy] = round(time.perf_counter() - started, 1)
        rows += each
        windows += spans
        learners += counts
        paths[strategy] = first.traces
        for vehicle, chromosome in enumerate(first.controllers):
            save_controller(out, f"table4/strategy{strategy}_vehicle{vehicle}", world.scenario,
                            chromosome, float("nan"))  # its generation's fittest, own lives
    measured = Measured(pd.DataFrame(rows), pd.DataFrame(windows), pd.DataFrame(learners))
    means = strategy_means(measured.situations)
    curve = learning_curve(measured.windows)
    write_csv(out / "simultaneous_situations.csv", measured.situations)
    write_csv(out / "simultaneous.csv", means.round(5).assign(
        wall_s=means["strategy"].map(wall)))
    write_csv(out / "table4_learners.csv", measured.learners)
    write_csv(out / "table4_learning.csv", curve)
    write_csv(out / "table4_learning_ends.csv", learning_ends(measured.windows))
    from enn_traffic.report.figures import crowd_learning_figure, crowd_paths_figure

    crowd_paths_figure(paths, out / "simultaneous_paths.png", DRAWN_SECONDS)
    crowd_learning_figure(curve, measured.situations, out / "table4_learning.png",
                          learning.learning_s, "the arena's 8 vehicles, mean of the situations "
                          f"in {SECONDS:g} s spans")
    return measured


def _inputs(study: Study) -> dict[int, tuple[np.ndarray, np.ndarray]]:
    """Per strategy: the winning chromosome and the evolved population, from the runs of
    individual learning (saved under ``controllers/``)."""
    family, out = study.settings(ARENA), study.out
    candidates = evolved_candidates(study, family)
    inputs = {}
    for strategy in ARENA.strategies:
        world = ArenaWorld(shipped_scenario(ARENA.name(strategy)))
        ranked = _ranked(world, candidates[strategy])
        winner = ranked[0]
        save_controller(out, f"table3/strategy{strategy}", world.scenario, winner,
                        float("nan"))  # chosen by lives lost, not by a fitness
        population = _evolved_population(
            ranked, final_population(study, family, strategy, winner),
            world.scenario.ga.population_size)
        save_arrays(out, f"table4/strategy{strategy}_evolved", population=population)
        inputs[strategy] = winner, population
    return inputs


def saved_inputs(out: Path) -> dict[int, tuple[np.ndarray, np.ndarray]]:
    """The winners and evolved populations :func:`_inputs` saved under ``out/controllers``."""
    folder = out / "controllers"
    inputs = {}
    for strategy in ARENA.strategies:
        with np.load(folder / "table4" / f"strategy{strategy}_evolved.npz") as saved:
            population = saved["population"]
        winner = Controller.load(folder / "table3" / f"strategy{strategy}.npz").chromosome
        inputs[strategy] = winner, population
    return inputs


def _measured(study: Study) -> Measured:
    return study.shared("simultaneous", lambda: measure(
        study.out, _inputs(study), study.settings(LEARNING), study.progress,
        _paper_winners(study)))


def paper_winner(out: Path, strategy: int, seeds: tuple[int, ...]) -> np.ndarray:
    """§5.5.1 the paper's way: of the strategy's runs of individual learning (under ``out``,
    one per seed), the best chromosome with the highest GA fitness (the first seed of
    equals), chosen by nothing the crowd showed (world layout)."""
    bests = [Controller.load(run_dir(ARENA, out, strategy, seed) / "best.npz")
             for seed in seeds]
    return max(bests, key=lambda best: best.fitness).chromosome


def _paper_winners(study: Study) -> dict[int, np.ndarray]:
    winners = {}
    for strategy in ARENA.strategies:
        best = paper_winner(study.out, strategy, study.settings(ARENA).seeds)
        save_controller(study.out, f"table3/strategy{strategy}_paper_way",
                        shipped_scenario(ARENA.name(strategy)), best, float("nan"))
        winners[strategy] = best
    return winners


def _reduction(means: pd.DataFrame, situations: pd.DataFrame, after: str, before: str) -> str:
    low, high = reduction_interval(situations, after, np.random.default_rng(0), before)
    return (f"{mean_reduction(means, after, before):.0%} (90% interval over the situations "
            f"{low:.0%} to {high:.0%})")


def _paper_way(situations: pd.DataFrame) -> str:
    """Table 3's winner the paper's way beside ours, in words chosen from the intervals."""
    means = strategy_means(situations)
    contrast = table4_comparisons(situations, arms=(), contrasts=[("paper_winner", "winner")],
                                  level=PAPER_WAY_LEVEL)
    name = "paper_winner_minus_winner"
    above, below = int((contrast[f"{name}_low"] > 0).sum()), int(
        (contrast[f"{name}_high"] < 0).sum())
    rates = ", ".join(f"strategy {s}: {a:.3f}" for s, a in zip(
        means["strategy"], means["paper_winner"], strict=True))
    return (f"the paper's winner (fittest by its GA fitness, no ranking in the crowd): {rates}"
            f"; its rate above ours in {above} of {len(contrast)} strategies and below in "
            f"{below} (paired {PAPER_WAY_LEVEL:.1%} intervals, 90% for the four together)")


def summary_lines(situations: pd.DataFrame, learners: pd.DataFrame, name: str) -> list[str]:
    """The summary's line for Table 3 (the first span) or Table 4 (the span after learning,
    every arm paired by situation)."""
    means = strategy_means(situations)
    if name == "table3":
        rates = ", ".join(f"strategy {s}: {i:.3f} -> {a:.3f}" for s, i, a in zip(
            means["strategy"], means["initial"], means["winner"], strict=True))
        line = (f"table3 (winner): collisions per second per vehicle, initial -> after: "
                f"{rates}; mean reduction {_reduction(means, situations, 'winner', 'initial')}"
                f"; paper: {PAPER_REDUCTION['table3']:.0%}")
        if "paper_winner" in situations:
            line += "; " + _paper_way(situations)
        return [line]
    bred = learners.groupby("strategy")["generations_bred"].median()
    rates = ", ".join(f"strategy {s}: {i:.3f} -> {a:.3f}" for s, i, a in zip(
        means["strategy"], means["initial_after"], means["population"], strict=True))
    comparisons = table4_comparisons(situations)

    def below(before: str) -> str:
        name = f"population_minus_{before}"
        lower = int((comparisons[name] < 0).sum())
        apart = int((comparisons[f"{name}_high"] < 0).sum())
        above = int((comparisons[f"{name}_low"] > 0).sum())
        return (f"below {ARMS[before]} in {lower} of {len(comparisons)} strategies "
                f"({apart} with the paired interval below 0, {above} above)")

    return [f"table4 (learning together, then each vehicle its evolved controller; the span "
            f"after learning): initial drivers driving on -> after learning: {rates}; mean "
            "reduction from the paper's baseline, the initial drivers' first span, "
            f"{_reduction(means, situations, 'population', 'initial')} (paper: "
            f"{PAPER_REDUCTION['table4']:.0%}); from the initial drivers driving on "
            f"{_reduction(means, situations, 'population', 'initial_after')}; "
            f"{below('winner_after')}; "
            f"{below('reranked')}; median generations bred per learner "
            f"{', '.join(f'{g:g}' for g in bred)}"]


def table3(study: Study) -> list[str]:
    """§5.5.1: the winning chromosome drives every vehicle."""
    measured = _measured(study)
    means = strategy_means(measured.situations)
    table = rates_table(means, "winner")
    if "paper_winner" in measured.situations:
        table["paper_winner_collisions_per_s"] = means["paper_winner"].round(4).to_numpy()
        contrast = table4_comparisons(measured.situations, arms=(),
                                      contrasts=[("paper_winner", "winner")], level=PAPER_WAY_LEVEL)
        table = table.merge(contrast, on="strategy")
    write_csv(study.out / "table3.csv", table)
    return table3_lines(study)


def table4(study: Study) -> list[str]:
    """§5.5.2: the evolved population, all vehicles learning at once."""
    measured = _measured(study)
    write_csv(study.out / "table4.csv", table4_comparisons(measured.situations))
    return table4_lines(study)


def _written(study: Study) -> tuple[pd.DataFrame, pd.DataFrame]:
    return (pd.read_csv(study.out / "simultaneous_situations.csv"),
            pd.read_csv(study.out / "table4_learners.csv"))


def table3_lines(study: Study) -> list[str]:
    """The summary's Table 3 line, from the tables the study wrote."""
    return summary_lines(*_written(study), "table3")


def table4_lines(study: Study) -> list[str]:
    """The summary's Table 4 line, from the tables the study wrote."""
    return summary_lines(*_written(study), "table4")


def facts(folder: Path) -> dict:
    """Facts (docs/_generate/README.md) of the arena's Tables 3–4 in a reproduce folder: the
    mean reductions of ``REDUCTIONS`` (:func:`mean_reduction` over ``simultaneous.csv``) with
    their 90% intervals over the situations (:func:`reduction_interval`, seed 0, over
    ``simultaneous_situations.csv``); the learning curve's ends (:func:`curve_facts`) and the
    learners' trend (:func:`trend_facts`); and, per strategy, how many of the first
    situation's controllers after learning (``controllers/table4``) are chromosomes of the
    evolved population the vehicles started from, and how many are distinct."""
    situations = pd.read_csv(folder / "simultaneous_situations.csv")
    means = pd.read_csv(folder / "simultaneous.csv")
    reductions = {}
    for after, before in REDUCTIONS:
        low, high = reduction_interval(situations, after, np.random.default_rng(0), before)
        reductions[f"{after}_vs_{before}"] = {"mean": mean_reduction(means, after, before),
                                              "low": low, "high": high}
    saved = folder / "controllers" / "table4"
    kept = []
    for strategy in ARENA.strategies:
        with np.load(saved / f"strategy{strategy}_evolved.npz") as evolved:
            start = {row.tobytes() for row in evolved["population"]}
        controllers = [Controller.load(path).chromosome
                       for path in sorted(saved.glob(f"strategy{strategy}_vehicle*.npz"))]
        kept.append({"strategy": strategy,
                     "kept": sum(chromosome.tobytes() in start for chromosome in controllers),
                     "distinct": len({chromosome.tobytes() for chromosome in controllers}),
                     "vehicles": len(controllers)})
    return {"reductions": reductions,
            "table4_vs_paper_table3": paired_by_strategy(situations, "population",
                                                         "paper_winner"),
            "table4_vs_table3": paired_by_strategy(situations, "population", "winner"),
            "curve": curve_facts(pd.read_csv(folder / "table4_learning.csv")),
            "trend": trend_facts(pd.read_csv(folder / "table4_learning_ends.csv")),
            "kept": kept}
