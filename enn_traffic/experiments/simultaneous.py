"""Paper §5.5: simultaneous collision avoidance — every vehicle of the arena driven by an
evolved network, spreading what individual learning (§5.3) found to all of them.

For each arena strategy and each of ``SITUATIONS`` traffic situations (the 8 start poses of
``scenarios/arena_strategyN``, headings drawn per situation), over ``SECONDS`` of simulated
time each:

- initial behaviour: all 8 vehicles driven by the strategy's own drivers;
- Table 3 (§5.5.1, broadcasting the winning chromosome): all 8 driven by the winning
  chromosome — of the controllers individual learning evolved on the strategy (every
  generation's best of every run, and the final elites), the one that loses fewest lives
  (collisions and spins) when it drives all 8 vehicles, judged on ``VALIDATION_SITUATIONS``
  situations apart from the measured ones;
- Table 4 (§5.5.2, broadcasting the evolved population): every vehicle starts from a copy of the
  evolved population (the candidates, fewest broadcast lives lost first, then the rest of the
  winner's run's final population) and all learn at once for ``SECONDS`` (each its own GA,
  sharing the best chromosomes across vehicles, docs/design.md, "The authors' code" 6); then
  each drives its own controller, "a customized solution for each different vehicle": of the
  chromosomes it drove itself, the one that lost fewest lives per step in its own lives
  (:meth:`~enn_traffic.evolution.online.OnlineLearning.own_controllers`), and the rate is
  measured over the ``SECONDS`` that follow (``population``). An alternative, from the same
  state after learning: all drive one pooled chromosome, the fewest lives lost per step over
  what every vehicle saw while learning and what the validation situations showed of each
  candidate (``pooled``).

Table 4 thus measures a later span than Table 3 and the initial behaviour, which start from
the start poses. So the initial drivers and the winner also drive on for a second span
(``initial_next``, ``winner_next`` in ``simultaneous.csv``): the like-for-like comparison.

The metric is :attr:`enn_traffic.sim.crowd.CrowdRun.collision_rate`. Evolved drivers are held
to §5.3's spin rule throughout: rotating in place ends a life (the vehicle respawns), so a
chromosome cannot avoid collisions by circling on the spot; their spins per second are
recorded beside the collisions.

Committed with the tables, under ``controllers/``: each strategy's winner
(``table3/strategyS.npz``), and for Table 4 its evolved population, what the validation
situations showed of each candidate (``table4/strategyS_evolved.npz``, ``_validation.npz``)
and each vehicle's own controller of the first situation (``table4/strategyS_vehicleV.npz``):
with them, that situation's every span can be driven again.
"""

from __future__ import annotations

import copy
import time
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd
from tqdm import tqdm

from enn_traffic import keys
from enn_traffic.evolution.online import Evidence, OnlineLearning, VehicleGA
from enn_traffic.experiments.choosing import evolved_candidates, final_population
from enn_traffic.experiments.common import distinct, save_arrays, save_controller
from enn_traffic.experiments.protocol import ARENA
from enn_traffic.experiments.study import Study
from enn_traffic.io import write_csv
from enn_traffic.report.plots import draw_paths, save_figure
from enn_traffic.runner import ga_params
from enn_traffic.shipped import shipped_scenario
from enn_traffic.sim.arena import ArenaWorld
from enn_traffic.sim.crowd import Crowd, CrowdRun
from enn_traffic.traffic.strategies import DRIVER_KINDS as DRIVERS
from enn_traffic.traffic.strategies import NETWORK

SECONDS = 100.0  # the paper's training time, and each measuring period
SITUATIONS = 20
SITUATION_KEY = keys.CROWD_TEST.start  # the situations whose rates are reported
VALIDATION_KEY = keys.CROWD_VALIDATION.start  # the situations that choose the winner
VALIDATION_SITUATIONS = 20
DRAWN_SECONDS = 20.0
# Mean reduction of the collision rate over the four strategies in the paper's Tables 3 and 4.
PAPER_REDUCTION = {"table3": 0.54, "table4": 0.89}


def _arena(world: ArenaWorld, situation: int, kinds=None, key: int = SITUATION_KEY
           ) -> tuple[Crowd, np.ndarray]:
    """The arena of one traffic situation: 8 start poses; ``kinds`` default to the strategy's
    own drivers; and the drivers' random genes (random-network strategy)."""
    episode = world.situations(key + situation)[0]
    strategy = DRIVERS[world.scenario.traffic.strategy_list[0]]
    kinds = np.full(world.vehicles, strategy) if kinds is None else kinds
    return Crowd(world, episode.start, kinds, int(episode.seed)), episode.traffic_genes.copy()


def _broadcast(world: ArenaWorld, genes: np.ndarray, situation: int, key: int = SITUATION_KEY,
               periods: int = 1) -> list[CrowdRun]:
    """``periods`` spans of ``SECONDS``, one after another, of one situation with ``genes``
    (world layout) driving every vehicle, held to the spin rule."""
    arena, _ = _arena(world, situation, np.full(world.vehicles, NETWORK), key)
    return [arena.run(SECONDS, np.tile(genes, (world.vehicles, 1)), check_spins=True)
            for _ in range(periods)]


def _ranked(world: ArenaWorld, candidates: np.ndarray, progress: bool = False
            ) -> tuple[np.ndarray, Evidence]:
    """The candidates, fewest lives lost (collisions and spins) first when each drives every
    vehicle on validation situations — the first is §5.5.1's winning chromosome — and what
    those situations showed of each (world layout)."""
    evidence = Evidence()
    source = world.spec.in_source_layout(candidates)
    for genes in tqdm(source, desc=f"ranking {world.scenario.name}", unit="candidate",
                      disable=not progress, leave=False):
        for situation in range(VALIDATION_SITUATIONS):
            run = _broadcast(world, genes, situation, VALIDATION_KEY)[0]
            evidence.record(genes, run.vehicle_steps,
                            int(run.collisions.sum() + run.spins.sum()))
    rates = [evidence.loss_rate(genes.tobytes()) for genes in source]
    return candidates[np.argsort(rates, kind="stable")], evidence


def evidence_arrays(evidence: Evidence) -> dict[str, np.ndarray]:
    """``evidence`` as arrays in the order it was recorded (which decides ties): each
    chromosome (source layout), the steps it drove and the lives it lost."""
    order = list(evidence.chromosomes)
    return {"chromosomes": np.stack([evidence.chromosomes[k] for k in order]),
            "steps": np.array([evidence.steps[k] for k in order]),
            "losses": np.array([evidence.losses[k] for k in order])}


def evidence_from_arrays(arrays) -> Evidence:
    """The :class:`Evidence` that :func:`evidence_arrays` wrote."""
    evidence = Evidence()
    for genes, steps, losses in zip(arrays["chromosomes"], arrays["steps"], arrays["losses"],
                                    strict=True):
        evidence.record(genes, int(steps), int(losses))
    return evidence


def _evolved_population(ranked: np.ndarray, run_population: np.ndarray, size: int
                        ) -> np.ndarray:
    """§5.5.2's evolved population: the ranked candidates, then the rest of the winner's run's
    final population, ``size`` distinct chromosomes at most."""
    return distinct(np.concatenate([ranked, run_population]))[:size]


def situation_rates(world: ArenaWorld, situation: int, winner: np.ndarray, evolved: np.ndarray,
                    validation: Evidence) -> tuple[dict[str, float], np.ndarray, tuple]:
    """One situation's rates (the columns of ``simultaneous_situations.csv``), each vehicle's
    own controller after learning (world layout) and the paths of the initial drivers, the
    winner and the vehicles after learning. ``winner`` (G,) and ``evolved`` (N, G) in the
    source layout; ``validation``: what the validation situations showed of the candidates."""
    sc = world.scenario
    network = np.full(world.vehicles, NETWORK)
    arena, genes = _arena(world, situation)
    initial = arena.run(SECONDS, genes)
    # the same drivers over the next SECONDS: the span Table 4 measures
    initial_next = arena.run(SECONDS, genes)
    broadcast, broadcast_next = _broadcast(world, winner, situation, periods=2)
    arena, _ = _arena(world, situation, network)
    learners = [VehicleGA(evolved.copy(), np.random.default_rng([sc.seed, situation, v]))
                for v in range(world.vehicles)]
    learning = OnlineLearning(learners, ga_params(sc), share_elites=True,
                              elite_count=sc.ga.elite_count, evidence=copy.deepcopy(validation))
    learnt = arena.run(SECONDS, np.tile(winner, (world.vehicles, 1)), learning)
    own = learning.own_controllers()
    pooled = arena.fork().run(SECONDS, np.tile(learning.evidence.best(), (world.vehicles, 1)),
                              check_spins=True)
    after = arena.run(SECONDS, own.copy(), check_spins=True)
    rates = {"initial": initial.collision_rate, "winner": broadcast.collision_rate,
             "learning": learnt.collision_rate, "population": after.collision_rate,
             "winner_spins": broadcast.spin_rate, "population_spins": after.spin_rate,
             "initial_next": initial_next.collision_rate,
             "winner_next": broadcast_next.collision_rate, "pooled": pooled.collision_rate,
             "pooled_spins": pooled.spin_rate}
    return (rates, world.spec.from_source_layout(own),
            (initial.trace, broadcast.trace, after.trace, world.track.walls))


def _strategy_rows(world: ArenaWorld, strategy: int, winner: np.ndarray, population: np.ndarray,
                   validation: Evidence, paths: dict, controllers: dict, progress: bool
                   ) -> tuple[dict, list[dict]]:
    """The strategy's mean rates (with the simulated and wall time they took) and each
    situation's; ``paths`` and ``controllers`` (each vehicle's own after learning) receive
    the first situation's."""
    winner_genes = world.spec.in_source_layout(winner)[0]
    evolved = world.spec.in_source_layout(population)
    situations = []
    started = time.perf_counter()
    for situation in tqdm(range(SITUATIONS), desc=f"arena_strategy{strategy} crowds",
                          unit="situation", disable=not progress, leave=False):
        rates, own, traces = situation_rates(world, situation, winner_genes, evolved,
                                             validation)
        situations.append({"strategy": strategy, "situation": situation, **rates})
        if situation == 0:
            paths[strategy], controllers[strategy] = traces, own
    wall = time.perf_counter() - started
    # initial and winner (two spans each), learning, after learning by own and pooled controllers
    simulated = SITUATIONS * SECONDS * 7
    columns = [k for k in situations[0] if k not in ("strategy", "situation")]
    means = {k: float(np.mean([row[k] for row in situations])) for k in columns}
    return ({"strategy": strategy, **means, "simulated_s": simulated,
             "wall_s": round(wall, 1)}, situations)


def _measure(study: Study) -> tuple[pd.DataFrame, pd.DataFrame]:
    """Every strategy's rates (Tables 3 and 4 share them): the means, also written to
    ``simultaneous.csv`` with the simulated and wall time they took, and each situation's,
    written to ``simultaneous_situations.csv``."""
    family, out = study.settings(ARENA), study.out
    candidates = evolved_candidates(study, family)
    rows, situations, paths, controllers = [], [], {}, {}
    for strategy in ARENA.strategies:
        world = ArenaWorld(shipped_scenario(ARENA.name(strategy)))
        ranked, validation = _ranked(world, candidates[strategy], study.progress)
        winner = ranked[0]
        save_controller(out, f"table3/strategy{strategy}", world.scenario, winner,
                        float("nan"))  # chosen by lives lost, not by a fitness
        population = _evolved_population(
            ranked, final_population(study, family, strategy, winner),
            world.scenario.ga.population_size)
        save_arrays(out, f"table4/strategy{strategy}_evolved", population=population)
        save_arrays(out, f"table4/strategy{strategy}_validation", **evidence_arrays(validation))
        means, each = _strategy_rows(world, strategy, winner, population, validation, paths,
                                     controllers, study.progress)
        for vehicle, chromosome in enumerate(controllers[strategy]):
            save_controller(out, f"table4/strategy{strategy}_vehicle{vehicle}", world.scenario,
                            chromosome, float("nan"))  # chosen by lives lost
        rows.append(means)
        situations.extend(each)
    table, situations = pd.DataFrame(rows), pd.DataFrame(situations)
    write_csv(out / "simultaneous.csv", table)
    write_csv(out / "simultaneous_situations.csv", situations)
    _draw_crowds(paths, out / "simultaneous_paths.png")
    return table, situations


def reduction_interval(situations: pd.DataFrame, after: str, rng: np.random.Generator,
                       draws: int = 2000, level: float = 0.9) -> tuple[float, float]:
    """How far the mean reduction over the strategies (1 − after / initial, each strategy's
    rates averaged over its situations) moves with the situations: its central ``level``
    interval when each strategy's situations are drawn again with replacement (bootstrap)."""
    groups = [group for _, group in situations.groupby("strategy")]
    reductions = np.zeros(draws)
    for group in groups:
        initial, later = group["initial"].to_numpy(), group[after].to_numpy()
        picks = rng.integers(0, len(group), (draws, len(group)))
        reductions += 1 - later[picks].mean(axis=1) / initial[picks].mean(axis=1)
    reductions /= len(groups)
    low, high = np.quantile(reductions, [(1 - level) / 2, (1 + level) / 2])
    return float(low), float(high)


def _draw_crowds(paths: dict, path: Path) -> None:
    """Each strategy: the first seconds of its initial drivers, the broadcast winner and the
    vehicles after simultaneous learning."""
    figure, axes = plt.subplots(3, 4, figsize=(16, 12))
    steps = round(DRAWN_SECONDS * 10)
    titles = ["initial drivers", "winning chromosome (Table 3)", "after learning (Table 4)"]
    for column, (strategy, traces) in enumerate(sorted(paths.items())):
        walls = traces[-1]
        for row, trace in enumerate(traces[:3]):
            ax = axes[row, column]
            draw_paths(ax, walls, [trace[:steps, v] for v in range(trace.shape[1])],
                       colors=[f"C{v}" for v in range(trace.shape[1])])
            ax.set_xticks([])
            ax.set_yticks([])
            ax.set_title(f"strategy {strategy}: {titles[row]}", fontsize=9)
    figure.suptitle(f"All 8 vehicles, first {DRAWN_SECONDS:g} s of simulated time")
    figure.tight_layout()
    save_figure(figure, path)


def _table(study: Study, after: str, name: str, label: str) -> list[str]:
    measured, situations = study.shared("simultaneous", lambda: _measure(study))
    table = rates_table(measured, after)
    write_csv(study.out / f"{name}.csv", table)
    return summary_lines(table, measured, situations, after, name, label)


def rates_table(measured: pd.DataFrame, after: str) -> pd.DataFrame:
    """Table 3 or 4 (``after``: ``winner`` or ``population``) from the strategies' mean
    rates: collisions per second per vehicle of the initial drivers and after."""
    return pd.DataFrame({"strategy": measured["strategy"],
                         "initial_collisions_per_s": measured["initial"].round(4),
                         "after_collisions_per_s": measured[after].round(4)})


def mean_reduction(rates: pd.DataFrame, after: str, before: str = "initial") -> float:
    """The mean over the strategies of 1 − ``after`` / ``before`` (columns of
    ``simultaneous.csv``): how much fewer collisions, strategy by strategy."""
    return float((1 - rates[after] / rates[before]).mean())


def summary_lines(table: pd.DataFrame, measured: pd.DataFrame, situations: pd.DataFrame,
                  after: str, name: str, label: str) -> list[str]:
    """The summary's line for Table 3 or 4; Table 4's leads with the like-for-like
    comparison."""
    reduction = 1 - table["after_collisions_per_s"] / table["initial_collisions_per_s"]
    low, high = reduction_interval(situations, after, np.random.default_rng(0))
    measure = (f"mean reduction {reduction.mean():.0%} (90% interval over the situations "
               f"{low:.0%}-{high:.0%}; paper: {PAPER_REDUCTION[name]:.0%})")
    rates = ", ".join(f"strategy {s}: {i:.3f} -> {a:.3f}"
                      for s, i, a in table.itertuples(index=False))
    simulated = (f"{measured['simulated_s'].sum():.0f} s simulated in "
                 f"{measured['wall_s'].sum():.0f} s")
    if after != "population":
        return [f"{name} ({label}): collisions per second per vehicle, initial -> after: "
                f"{rates}; {measure}; {simulated}"]
    # Like for like first: the learners are measured in the span after learning, so the
    # initial drivers' and the winner's own second spans are the fair comparison.
    same_span = mean_reduction(measured, "population", "initial_next")
    driving_on = mean_reduction(measured, "winner_next", "initial_next")
    pooled = mean_reduction(measured, "pooled", "initial_next")
    like = ", ".join(f"strategy {s}: {i:.3f} -> {a:.3f}" for s, i, a in zip(
        measured["strategy"], measured["initial_next"], measured["population"], strict=True))
    return [f"{name} ({label}): like for like, both over the second {SECONDS:g} s, collisions "
            f"per second per vehicle, initial drivers -> after learning, each vehicle its own "
            f"controller: {like}; mean reduction {same_span:.0%}, where the winner "
            f"driving on without learning reaches {driving_on:.0%} and all driving one "
            f"pooled chromosome after learning {pooled:.0%}. Against the initial "
            f"drivers' first {SECONDS:g} s (table4.csv): {rates}; {measure}; {simulated}"]


def table3(study: Study) -> list[str]:
    """§5.5.1: the winning chromosome drives every vehicle."""
    return _table(study, "winner", "table3", "winner")


def table4(study: Study) -> list[str]:
    """§5.5.2: the evolved population, all vehicles learning at once."""
    return _table(study, "population", "table4", "population")
