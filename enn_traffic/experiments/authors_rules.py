"""The authors' set-up's three rules, one at a time (docs/departures.md, "Learning while
driving").

Table 4's ablation measures the authors' set-up whole: random populations and the finishing
rule (the 2 × 2's ``random, finish`` arm), plus three rules of their code that the 2 × 2 keeps
ours (:class:`~enn_traffic.experiments.ablation.AuthorsRules`):

- **respawn at own start**: a car that collides or spins starts again at its own start pose
  (reference §7.3); ours at a random free spot;
- **their spin rule**: a car whose last 4.9 s of positions vary by at most 64 m² in x and in y
  has spun (reference §6.2); ours is the scenario's;
- **until every car finished**: the learning goes on until every car has finished (kept a
  chromosome whose life lasted 2000 steps) or bred 100 generations, at most four times Table
  4's learning time (reference §7.5); ours learns Table 4's time.

Here the set-up without the three (``none``) is set against each rule alone and all three,
paired by situation on keys of their own: the collisions per vehicle-second of the learning's
first span and of the span after learning, the difference between them, and the fall from
the first to after (the paper's Table 4 figure), with bootstrap intervals simultaneous over the
table (Bonferroni, 90% for the family). Written to ``authors_rules.csv`` and
``authors_rules_situations.csv``.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np
import pandas as pd

from enn_traffic.core import keys
from enn_traffic.core.io import write_csv
from enn_traffic.experiments.ablation import ABLATION, DRAWS, LEVEL, AuthorsRules, authors_arm
from enn_traffic.experiments.common import over_situations
from enn_traffic.experiments.departures import strategy_world
from enn_traffic.experiments.study import Study
from enn_traffic.report.stats import bootstrap_interval

RULES_KEY = keys.AUTHORS_RULES.start
NONE = "none"
VARIANTS = {
    NONE: AuthorsRules(respawn_at_start=False, spin_rule=False, until_finished=False),
    "respawn at own start": AuthorsRules(spin_rule=False, until_finished=False),
    "their spin rule": AuthorsRules(respawn_at_start=False, until_finished=False),
    "until every car finished": AuthorsRules(respawn_at_start=False, spin_rule=False),
    "all three": AuthorsRules(),
}
MEASURES = {"first_span": "the learning's first span",
            "after": "the span after learning",
            "after_minus_first_span": "the change from the first span to after learning"}


@dataclass(frozen=True)
class Steps:
    """In how many situations, how long each variant learns (Table 4's ablation's times), and
    what ``--quick`` changes."""

    situations: int = ABLATION.situations
    seconds: float = ABLATION.seconds
    authors_seconds: float = ABLATION.authors_seconds
    quick: dict = field(default_factory=lambda: {"situations": 2, "seconds": 300.0,
                                                 "authors_seconds": 1100.0})


STEPS = Steps()


def situation_rows(situation: int, settings: Steps = STEPS, key: int = RULES_KEY) -> list[dict]:
    """One situation under every variant: a row each, with its measures."""
    world = strategy_world(1)  # every car learns from a random population: strategy-free
    learning = replace(ABLATION, seconds=settings.seconds,
                       authors_seconds=settings.authors_seconds)
    rows = []
    for name, rules in VARIANTS.items():
        learnt, after, online, seconds = authors_arm(world, situation, learning, key, rules)
        first = learnt[0].collision_rate
        rows.append({"situation": situation, "variant": name, "first_span": first,
                     "after": after.collision_rate, "after_minus_first_span":
                     after.collision_rate - first, "learning_s": seconds,
                     "finished_share": float(np.mean([g.finished for g in online.learners]))})
    return rows


def fall_interval(first: np.ndarray, after: np.ndarray, rng: np.random.Generator,
                  level: float) -> tuple[float, float]:
    """A percentile bootstrap interval of 1 − mean(after) / mean(first), situations resampled
    in pairs."""
    picks = rng.integers(0, len(first), (DRAWS, len(first)))
    falls = 1 - after[picks].mean(axis=1) / first[picks].mean(axis=1)
    tail = (1 - level) / 2
    return float(np.quantile(falls, tail)), float(np.quantile(falls, 1 - tail))


def rules_table(situations: pd.DataFrame, seed: int = 0) -> pd.DataFrame:
    """Per variant: the mean of each measure, the fall from the first span to after learning
    with its interval, and (but for ``none``) each measure's paired difference from ``none``
    with its interval; every interval simultaneous over the table."""
    base = situations[situations["variant"] == NONE].set_index("situation")
    others = len(VARIANTS) - 1
    level = 1 - (1 - LEVEL) / (len(VARIANTS) + others * len(MEASURES))
    rng = np.random.default_rng(seed)
    rows = []
    for name in VARIANTS:
        mine = situations[situations["variant"] == name].set_index("situation")
        first, after = mine["first_span"].to_numpy(), mine["after"].to_numpy()
        row = {"variant": name, "situations": len(mine),
               **{measure: mine[measure].mean() for measure in MEASURES},
               "fall": 1 - after.mean() / first.mean() if first.mean() > 0 else float("nan")}
        row["fall_low"], row["fall_high"] = fall_interval(first, after, rng, level)
        for measure in MEASURES:
            difference = (mine[measure] - base[measure]).to_numpy()
            low, high = ((np.nan, np.nan) if name == NONE
                         else bootstrap_interval(difference, rng, DRAWS, level))
            row |= {f"{measure}_vs_none": difference.mean() if name != NONE else np.nan,
                    f"{measure}_vs_none_low": low, f"{measure}_vs_none_high": high}
        row |= {"learning_s": mine["learning_s"].median(),
                "finished_share": mine["finished_share"].mean()}
        rows.append(row)
    return pd.DataFrame(rows).round(5)


def authors_rules(study: Study) -> list[str]:
    """``authors_rules.csv``: the authors' set-up's three rules, each alone and together."""
    settings = study.settings(STEPS)
    situations = over_situations(situation_rows, settings.situations, settings,
                                 "authors' rules", study.progress)
    table = rules_table(situations)
    write_csv(study.out / "authors_rules_situations.csv", situations.round(5))
    write_csv(study.out / "authors_rules.csv", table)
    return authors_rules_lines(study)


def authors_rules_lines(study: Study) -> list[str]:
    """The summary's line, from the ``authors_rules.csv`` the study wrote."""
    table = pd.read_csv(study.out / "authors_rules.csv")
    count = int(table["situations"].iloc[0])
    return [f"the authors' rules ({count} situations, the fall from the learning's first span "
            "to after it): " + "; ".join(f"{row.variant} {row.fall:.0%} ({row.fall_low:.0%} "
                                         f"to {row.fall_high:.0%})"
                                         for row in table.itertuples())]

