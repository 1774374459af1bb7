"""Tables 3–4 among SUMO traffic (paper §5.5 on a SUMO family of strategies: ``sumo_strategy1..4``
or the city's; docs/sumo.md).

``traffic.learners`` learners (8) drive at once in one live SUMO, among its own traffic
(:mod:`enn_traffic.sim.sumo_crowd`). For each strategy and each of the ``CROWD_SPANS``'
situations (10), over spans of its seconds (100) of SUMO time:

- initial drivers: every learner a random network (drawn per situation), two spans one after
  the other (``initial``, ``initial_next``);
- Table 3 (§5.5.1): every learner drives the winning chromosome, two spans (``winner``,
  ``winner_next``). The winner is the strategy's Table 1 controller, chosen among the
  controllers individual learning evolved on validation traffic: ranking every candidate by
  broadcasting it, as the arena does, would cost about 10 min of SUMO time per strategy;
- Table 4 (§5.5.2): every learner starts from a copy of the evolved population (the final
  population of the winner's run) and all learn at once for a span, each its own GA sharing
  the best chromosomes (``learning``); then each drives its own controller, the chromosome
  that lost fewest lives per step in its own lives (``population``), over the span after it.
  Its like-for-like comparisons are the second spans of the initial drivers and of the
  winner. (A live SUMO cannot be forked, so the arena's pooled alternative is not run here.)

Rates are responsible collisions per learner-second (:attr:`SumoCrowdRun.collision_rate`) and
SUMO's SSM conflicts, time-to-collision below 1.5 s, per learner-hour, each with a 90%
bootstrap interval over the situations. The situations' SUMO seeds come from the crowd test
keys (:data:`enn_traffic.keys.CROWD_TEST`), which no choice looked at.

Committed with the tables, under ``controllers/<family>/table4/``: each strategy's evolved
population (``strategyS_evolved.npz``) and each learner's own controller of the first
situation (``strategyS_learnerK.npz``); with the Table 1 controllers they drive that situation
again.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np
import pandas as pd
from tqdm import tqdm

from enn_traffic import keys
from enn_traffic.evolution.online import OnlineLearning, VehicleGA
from enn_traffic.experiments.choosing import final_population, specialists
from enn_traffic.experiments.common import save_arrays, save_controller
from enn_traffic.experiments.protocol import SUMO, Family
from enn_traffic.experiments.study import Study
from enn_traffic.io import write_csv
from enn_traffic.runner import ga_params
from enn_traffic.sim.sumo_crowd import SumoCrowd
from enn_traffic.sim.sumo_world import SumoWorld
from enn_traffic.worlds import make_world

SITUATION_KEY = keys.SPENT_CROWD_TEST.start  # until measured again (keys.py)
SPANS = ["initial", "initial_next", "winner", "winner_next", "learning", "population"]


@dataclass(frozen=True)
class Spans:
    """How long each span is (SUMO seconds) and how many situations each strategy is measured
    in, and what ``--quick`` changes of them."""

    seconds: float
    situations: int
    quick: Mapping[str, object] = field(default_factory=dict)


# 100 s: the paper's learning time, and each measured span
CROWD_SPANS = Spans(seconds=100.0, situations=10, quick={"seconds": 20.0, "situations": 2})


def situation_rates(world: SumoWorld, winner: np.ndarray, evolved: np.ndarray, situation: int,
                    seconds: float) -> tuple[dict[str, float], np.ndarray]:
    """One situation's spans (``SPANS``): collisions per learner-second and SSM conflicts per
    learner-hour (``<span>_conflicts``), and each learner's own controller after learning
    (K, G). ``winner`` (G,), ``evolved`` (N, G) and the controllers in the source layout."""
    scenario = world.scenario
    count = scenario.traffic.learners
    seed = world.seeds(SITUATION_KEY + situation)[0]
    rng = np.random.default_rng([scenario.traffic.seed, SITUATION_KEY, situation])
    runs = {}
    drivers = world.spec.in_source_layout(
        rng.uniform(-1, 1, (count, world.spec.chromosome_length)))
    with SumoCrowd(world, seed) as crowd:
        runs["initial"] = crowd.run(seconds, drivers)
        runs["initial_next"] = crowd.run(seconds, drivers)
    broadcast = np.tile(winner, (count, 1))
    with SumoCrowd(world, seed) as crowd:
        runs["winner"] = crowd.run(seconds, broadcast)
        runs["winner_next"] = crowd.run(seconds, broadcast)
    learners = [VehicleGA(evolved.copy(), np.random.default_rng([scenario.seed, situation, k]))
                for k in range(count)]
    learning = OnlineLearning(learners, ga_params(scenario), share_elites=True,
                              elite_count=scenario.ga.elite_count)
    with SumoCrowd(world, seed) as crowd:
        runs["learning"] = crowd.run(seconds, broadcast, learning)
        controllers = learning.own_controllers()
        runs["population"] = crowd.run(seconds, controllers.copy())
    rates = {span: run.collision_rate for span, run in runs.items()}
    rates |= {f"{span}_conflicts": run.conflict_rate for span, run in runs.items()}
    return rates, controllers


def interval(values: np.ndarray, rng: np.random.Generator, draws: int = 2000,
             level: float = 0.9) -> tuple[float, float]:
    """The central ``level`` interval of the mean of ``values`` when they are drawn again
    with replacement (bootstrap)."""
    values = np.asarray(values, dtype=np.float64)
    means = values[rng.integers(0, len(values), (draws, len(values)))].mean(axis=1)
    low, high = np.quantile(means, [(1 - level) / 2, (1 + level) / 2])
    return float(low), float(high)


def crowd_world(family: Family, strategy: int) -> SumoWorld:
    """The strategy's test world with its SUMO in closed loop (the learners are in it), and the
    GA settings its populations evolved with."""
    return make_world(family.scenario(strategy).with_overrides(
        ga=dict(family.ga), traffic={"mode": "closed-loop"}))


def measure(study: Study, family: Family) -> pd.DataFrame:
    """Every strategy's situations, written to ``<family folder>/crowd_situations.csv``."""
    controllers = specialists(study, family)
    spans = study.settings(CROWD_SPANS)
    rows = []
    with tqdm(total=len(family.strategies) * spans.situations, unit="situation",
              desc=f"{family.folder} crowds", disable=not study.progress, leave=False) as bar:
        for strategy in family.strategies:
            world = crowd_world(family, strategy)
            winner = controllers[strategy]
            evolved = final_population(study, family, strategy, winner)
            source = world.spec.in_source_layout(np.vstack([winner, evolved]))
            save_arrays(study.out, f"{family.folder}/table4/strategy{strategy}_evolved",
                        population=evolved)
            for situation in range(spans.situations):
                rates, own = situation_rates(world, source[0], source[1:], situation,
                                             spans.seconds)
                rows.append({"strategy": strategy, "situation": situation, **rates})
                bar.update(1)
                if situation == 0:  # each learner's own controller, committed with the tables
                    for learner, genes in enumerate(world.spec.from_source_layout(own)):
                        save_controller(study.out, f"{family.folder}/table4/strategy"
                                        f"{strategy}_learner{learner}", world.scenario, genes,
                                        float("nan"))
    table = pd.DataFrame(rows)
    write_csv(study.out / family.folder / "crowd_situations.csv", table)
    return table


def table(situations: pd.DataFrame, columns: list[str]) -> pd.DataFrame:
    """Per strategy: the mean of each span's collision and conflict rates, with the 90%
    interval of the collision rate over the situations."""
    rng = np.random.default_rng(0)
    rows = []
    for strategy, group in situations.groupby("strategy"):
        row = {"strategy": strategy}
        for span in columns:
            low, high = interval(group[span].to_numpy(), rng)
            row |= {f"{span}_collisions_per_s": round(group[span].mean(), 4),
                    f"{span}_low": round(low, 4), f"{span}_high": round(high, 4),
                    f"{span}_conflicts_per_h": round(group[f"{span}_conflicts"].mean(), 1)}
        rows.append(row)
    return pd.DataFrame(rows)


def sumo_tables(study: Study, family: Family = SUMO) -> list[str]:
    """A SUMO family's Table 3 (the winner broadcast, against the initial drivers, from the
    learners' entry) and Table 4 (after learning together, against both drivers' second
    spans), into ``<family folder>/table3.csv`` and ``table4.csv``."""
    family = study.settings(family)
    situations = measure(study, family)
    table3 = table(situations, ["initial", "winner"])
    table4 = table(situations, ["initial_next", "winner_next", "population"])
    write_csv(study.out / family.folder / "table3.csv", table3)
    write_csv(study.out / family.folder / "table4.csv", table4)

    def entries(frame: pd.DataFrame, before: str, after: str) -> str:
        return ", ".join(
            f"strategy {int(r['strategy'])}: {r[f'{before}_collisions_per_s']:.3f} -> "
            f"{r[f'{after}_collisions_per_s']:.3f}" for _, r in frame.iterrows())

    return [f"{family.folder}/table3: collisions per learner-second, initial drivers -> winner: "
            f"{entries(table3, 'initial', 'winner')}",
            f"{family.folder}/table4: collisions per learner-second over the second span, initial "
            f"drivers -> after learning together: {entries(table4, 'initial_next', 'population')}"
            f"; the winner driving on: {entries(table4, 'initial_next', 'winner_next')}"]
