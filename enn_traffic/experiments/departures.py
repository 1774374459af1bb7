"""The crowds' last departures from the authors' rules, measured (docs/departures.md).

Three rules of the authors' code that the crowds do not follow even in Table 4's ablation's
authors' set-up (:class:`~enn_traffic.experiments.ablation.AuthorsRules`):

- **blame after a respawn**: the authors clear every car's previous body whenever any car
  respawns, so for one step every car is tested against the others' current bodies (reference
  §7.3); ours clears only the respawned car's;
- **vehicle 0's heading**: the authors draw every car's start heading; ours starts vehicle 0
  at the scenario's 90°;
- **breeding**: the authors breed a car's children from its best 180 of 200; ours draws the
  tournaments from all 200.

Each, and all three together, is set against the authors' set-up as measured (ours in those
three rules), paired by situation on keys of its own: the collisions per vehicle-second of the
learning's first span, of its spans 2–11, of the span after learning and the fall from the first
span to it (Table 4's ablation's measures), and of the initial drivers' first span (Table 3's
initial column; every strategy, the mean per situation), where breeding plays no part.
Bootstrap intervals of the differences are simultaneous over the table (Bonferroni, 90% for the
family). Written to ``departures.csv`` and ``departures_situations.csv``.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from functools import cache

import numpy as np
import pandas as pd

from enn_traffic.config.shipped import shipped_scenario
from enn_traffic.config.traffic import STRATEGIES
from enn_traffic.core import keys
from enn_traffic.core.io import write_csv
from enn_traffic.experiments.ablation import (
    ABLATION,
    DRAWS,
    EARLY_SPANS,
    LEVEL,
    AuthorsRules,
    authors_arm,
    start_poses,
)
from enn_traffic.experiments.common import over_situations
from enn_traffic.experiments.crowds.arena import SECONDS
from enn_traffic.experiments.families import ARENA
from enn_traffic.experiments.study import Study
from enn_traffic.report.stats import bootstrap_interval
from enn_traffic.sim.arena import ArenaWorld
from enn_traffic.sim.crowd import Crowd

DEPARTURE_KEY = keys.DEPARTURES.start
VARIANTS = {
    "ours": AuthorsRules(),
    "blame after a respawn": AuthorsRules(blame_all_after_respawn=True),
    "vehicle 0's heading": AuthorsRules(vehicle0_heading_drawn=True),
    "breeding from the best 180": AuthorsRules(breed_from_best=True),
    "all three": AuthorsRules(True, True, True),
}
MEASURES = {"first_span": "the learning's first span",
            "early_spans": "the learning's spans 2–11",
            "after": "the span after learning",
            "after_minus_first_span": "after learning − the first span",
            "initial_first": "the initial drivers' first span"}


@dataclass(frozen=True)
class Departures:
    """In how many situations, how long the authors' set-up learns at most (Table 4's
    ablation's), and what ``--quick`` changes."""

    situations: int = ABLATION.situations
    authors_seconds: float = ABLATION.authors_seconds
    quick: dict = field(default_factory=lambda: {"situations": 2, "authors_seconds": 1100.0})


DEPARTURES = Departures()


@cache
def strategy_world(strategy: int) -> ArenaWorld:
    """The arena of ``strategy``'s shipped scenario, built once."""
    return ArenaWorld(shipped_scenario(ARENA.name(strategy)))


def initial_drivers(situation: int, rules: AuthorsRules, key: int = DEPARTURE_KEY) -> float:
    """Every strategy's initial drivers over one span of the situation (their mean rate), by
    ``rules``' blame and start heading."""
    rates = []
    for strategy in ARENA.strategies:
        world = strategy_world(strategy)
        chosen = world.situations(key + situation)[0]
        kind = STRATEGIES[world.scenario.traffic.strategy_list[0]]
        crowd = Crowd(world, start_poses(world, chosen, key + situation, rules),
                      np.full(world.vehicles, kind), int(chosen.seed),
                      blame_all_after_respawn=rules.blame_all_after_respawn)
        rates.append(crowd.run(SECONDS, chosen.traffic_genes.copy()).collision_rate)
    return float(np.mean(rates))


def moves_initial(rules: AuthorsRules) -> bool:
    """Do ``rules`` change how the initial drivers drive or are counted (breeding does not)?"""
    return rules.blame_all_after_respawn or rules.vehicle0_heading_drawn


def situation_rows(situation: int, settings: Departures = DEPARTURES, key: int = DEPARTURE_KEY
                   ) -> list[dict]:
    """One situation under every variant: a row each, with its measures."""
    world = strategy_world(1)  # the learning is strategy-free
    learning = replace(ABLATION, authors_seconds=settings.authors_seconds)
    rows = []
    for name, rules in VARIANTS.items():
        learnt, after, _, seconds = authors_arm(world, situation, learning, key, rules)
        initial = (initial_drivers(situation, rules, key) if moves_initial(rules) or not rows
                   else rows[0]["initial_first"])
        rows.append({"situation": situation, "variant": name,
                     "first_span": learnt[0].collision_rate,
                     "early_spans": float(np.mean([run.collision_rate
                                                   for run in learnt[EARLY_SPANS]])),
                     "after": after.collision_rate,
                     "after_minus_first_span": after.collision_rate - learnt[0].collision_rate,
                     "initial_first": initial, "learning_s": seconds})
    return rows


def departures_table(situations: pd.DataFrame, seed: int = 0) -> pd.DataFrame:
    """Each departure's paired difference from ours (the authors' rule − ours) in each
    measure, intervals simultaneous over the table. Breeding plays no part in the initial
    drivers: no row."""
    ours = situations[situations["variant"] == "ours"].set_index("situation")
    rows = []
    for name in list(VARIANTS)[1:]:
        theirs = situations[situations["variant"] == name].set_index("situation")
        for measure in MEASURES:
            if measure == "initial_first" and not moves_initial(VARIANTS[name]):
                continue
            rows.append({"departure": name, "measure": measure, "situations": len(theirs),
                         "ours": ours[measure].mean(), "authors": theirs[measure].mean(),
                         "difference": (theirs[measure] - ours[measure]).to_numpy()})
    level = 1 - (1 - LEVEL) / len(rows)
    rng = np.random.default_rng(seed)
    for row in rows:
        low, high = bootstrap_interval(row["difference"], rng, DRAWS, level)
        row["difference"] = float(row["difference"].mean())
        row["difference_low"], row["difference_high"] = low, high
    return pd.DataFrame(rows).round(5)


def departures(study: Study) -> list[str]:
    """``departures.csv``: each of the three departures' effect in the authors' set-up."""
    settings = study.settings(DEPARTURES)
    situations = over_situations(situation_rows, settings.situations, settings, "departures",
                                 study.progress)
    table = departures_table(situations)
    write_csv(study.out / "departures_situations.csv", situations.round(5))
    write_csv(study.out / "departures.csv", table)
    return departures_lines(study)


def departures_lines(study: Study) -> list[str]:
    """The summary's line, from the ``departures.csv`` the study wrote: the differences apart
    from 0, how wide the intervals are beside the rate after learning, and the differences
    that are 0 in every situation (no interval to read)."""
    table = pd.read_csv(study.out / "departures.csv")
    count = int(table["situations"].iloc[0])
    apart = table[(table["difference_low"] > 0) | (table["difference_high"] < 0)]
    after = table[table["measure"] == "after"]
    widest = after.loc[after["difference_high"].idxmax()]
    zero = table[(table["difference_low"] == 0) & (table["difference_high"] == 0)]
    return [f"departures ({count} situations, in the authors' set-up only, the authors' rule − "
            f"ours, collisions per vehicle-second): {len(apart)} of {len(table)} differences "
            "apart from 0"
            + "".join(f"; {row.departure}, {row.measure}: {row.difference:+.4f} "
                      f"({row.difference_low:+.4f} to {row.difference_high:+.4f})"
                      for row in apart.itertuples())
            + f"; no evidence of no effect: the intervals are wide beside the rates (after "
            f"learning, ours {widest['ours']:.4f}; {widest['departure']} up to "
            f"{widest['difference_high']:+.4f})"
            + "".join(f"; {row.departure}, {row.measure}: 0 in every situation"
                      for row in zero.itertuples())]
