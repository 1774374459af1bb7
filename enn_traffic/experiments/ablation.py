"""Table 4 as an ablation (paper §5.5.2): which procedural choice carries the pattern.

Table 4 differs from the authors' procedure (reference §7) in two choices that this experiment
crosses (docs/departures.md, "Learning while driving"): our learners start from the evolved
population, theirs from random populations (their code cannot load an evolved one); our
chromosome's trial ends at a 300-step life cap, theirs has no cap and a vehicle keeps a
chromosome for good once a life with it lasted 2000 steps (reference §7.5,
``GA.goodFitness``). Every arm of that 2 × 2 keeps our respawn at a free spot, our spin rule and
our blame rule. Two more arms: ``evolved, frozen`` — each vehicle a distinct chromosome of the
evolved population, no learning (what mixing controllers does without learning) — and
``authors`` — their whole set-up as far as it is measured here: random populations, the
finishing rule, respawn at the car's own start, their 4.9 s spin rule, learning until every car
has finished or bred 100 generations (at most ``authors_seconds``).

Arms in which every vehicle learns from random populations do not depend on the strategy (the
strategy decides the initial drivers and the evolved population only): they are driven once per
situation and set against each strategy's other arms. For every arm, the collisions per
vehicle-second of the span after learning are set against (a) the arm's own first span (the
paper's baseline), (a') its spans 2–11 (the first span starts with the 8 vehicles close
together at their start poses), (b) the initial drivers and (c) the winner driving on over the
same span, and (d) the winner's first span (Table 3, as the paper sets its tables side by
side); paired by situation, bootstrap intervals simultaneous over the whole table (Bonferroni:
90% for the family). ``table4_ablation_factors.csv`` gives each choice's effect in the 2 × 2,
the mean over strategies and the other choice, with its interval.

A first reading on keys 10·10⁹ + 0…19 had only (a), (b) and (c), and no frozen and no authors'
arm; a review of it found the winner driving on near 0 and the first span crowded, so the
design changed and this one reads fresh keys (docs/results.md says what the first found).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field, replace
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd
from tqdm import tqdm

from enn_traffic.config.shipped import shipped_scenario
from enn_traffic.core import keys
from enn_traffic.core.errors import InputError
from enn_traffic.core.io import write_csv
from enn_traffic.core.progress import terminal
from enn_traffic.experiments.crowds.arena import (
    LEARNING,
    SECONDS,
    _broadcast,
    learn_together,
    saved_inputs,
    situation_crowd,
)
from enn_traffic.experiments.crowds.stats import (
    curve_ends,
    mean_reduction,
    paired_by_strategy,
    reduction_interval,
)
from enn_traffic.experiments.families import ARENA
from enn_traffic.experiments.regime import AUTHORS_SPIN
from enn_traffic.experiments.study import Study
from enn_traffic.learning import ga
from enn_traffic.learning.online import OnlineLearning, VehicleGA
from enn_traffic.report.plots import save_figure
from enn_traffic.report.stats import bootstrap_interval, t_interval
from enn_traffic.sim.arena import ArenaWorld, Situation
from enn_traffic.sim.crowd import Crowd
from enn_traffic.sim.strategies import NETWORK

ABLATION_KEY = keys.ABLATION_ARENA.start
FINISH_STEPS = 2000  # reference §7.5: GA.goodFitness
AUTHORS_GENERATIONS = 100  # reference §7.5: GA.nbrOfGenerations_max
STARTS = ("random", "evolved")
STOPPINGS = {"cap": {"life_cap_steps": LEARNING.life_cap_steps, "finish_steps": 0},
             "finish": {"life_cap_steps": 0, "finish_steps": FINISH_STEPS}}
# (start population, stopping): the 2 × 2, then the frozen arm and the authors' set-up
ARMS = [(start, stopping) for start in STARTS for stopping in STOPPINGS] + [
    ("evolved", "frozen"), ("authors", "authors")]
SHARED = {("random", "cap"), ("random", "finish"), ("authors", "authors")}  # any strategy
EARLY_SPANS = slice(1, 11)  # spans 2–11 of the learning
OWN = ("first_span", "early_spans")  # the contrasts against an arm's own spans
# the span after learning against: (a), (a') the arm's own spans, (b)-(d) the other arms
CONTRASTS = {"first_span": "its own first span",
             "early_spans": "its own spans 2–11",
             "initial_after": "the initial drivers driving on",
             "winner_after": "the winner driving on",
             "winner_first": "the winner's first span (Table 3)"}
LEVEL = 0.9  # for the whole family of intervals of a table
DRAWS = 20000  # bootstrap draws: the family's level leaves about 0.1% in each tail


@dataclass(frozen=True)
class Ablation:
    """How long each arm learns (the authors' set-up: until every car finished, at most
    ``authors_seconds``), in how many situations per strategy, and what ``--quick`` changes
    of them; Table 4's learning time (``crowds.arena.LEARNING``) by default."""

    seconds: float = LEARNING.learning_s
    authors_seconds: float = 4 * LEARNING.learning_s
    situations: int = LEARNING.situations
    quick: dict = field(default_factory=lambda: {"seconds": 300.0, "authors_seconds": 600.0,
                                                 "situations": 2})


ABLATION = Ablation()


def _row(start: str, stopping: str, learnt: list, after, online: OnlineLearning | None,
         seconds: float) -> dict:
    learners = pd.DataFrame(online.learner_rows()) if online is not None else pd.DataFrame()
    return {"start_population": start, "stopping": stopping,
            "first_span": learnt[0].collision_rate,
            "early_spans": float(np.mean([run.collision_rate for run in learnt[EARLY_SPANS]])),
            "after": after.collision_rate, "after_spins": after.spin_rate,
            "learning_s": seconds,
            "generations_bred": float(learners["generations_bred"].median())
            if len(learners) else 0.0,
            "finished_share": float(learners["finished"].mean())
            if "finished" in learners else 0.0}


@dataclass(frozen=True)
class AuthorsRules:
    """Which of the authors' rules their set-up (:func:`authors_arm`) takes beyond random
    populations and the finishing rule. By default the three it is measured with in the
    ablation (each measured alone by :mod:`enn_traffic.experiments.authors_rules`): a car
    respawns at its own start (reference §7.3), their 4.9 s spin rule (reference §6.2), and
    learning until every car finished (reference §7.5; else Table 4's learning time). Not by
    default the three where the crowds keep ours even there (docs/departures.md; measured by
    :mod:`enn_traffic.experiments.departures`): blame against every car's current body for
    the step after any respawn (reference §7.3), vehicle 0's start heading drawn like every
    car's (reference §1.4), breeding from a car's best 180 (reference §7.4)."""

    blame_all_after_respawn: bool = False
    vehicle0_heading_drawn: bool = False
    breed_from_best: bool = False
    respawn_at_start: bool = True
    spin_rule: bool = True
    until_finished: bool = True


def start_poses(world: ArenaWorld, chosen: Situation, key: int,
                rules: AuthorsRules = AuthorsRules()) -> np.ndarray:
    """The start poses (V, 3) of situation ``chosen``, drawn from traffic key ``key``; with
    ``rules.vehicle0_heading_drawn`` vehicle 0's heading drawn from the traffic's start
    headings, as every other's."""
    start = chosen.start.copy()
    if rules.vehicle0_heading_drawn:
        traffic = world.scenario.traffic
        low, high = np.radians(traffic.start_heading_deg)
        start[0, 2] = np.random.default_rng([traffic.seed, key, 0]).uniform(low, high)
    return start


def authors_arm(world: ArenaWorld, situation: int, ablation: Ablation, key: int,
                rules: AuthorsRules = AuthorsRules()
                ) -> tuple[list, object, OnlineLearning, float]:
    """The authors' set-up (reference §7): every car learning from a random population with
    the finishing rule, respawning at its own start, held to their spin rule, until every car
    finished or bred ``AUTHORS_GENERATIONS`` (at most ``ablation.authors_seconds``); the runs
    of its spans, the span after it, the learning and its length (s). ``rules``: which of the
    authors' rules it takes (:class:`AuthorsRules`; without ``until_finished`` it learns
    ``ablation.seconds``, Table 4's time)."""
    sc = world.scenario.with_overrides(episode=AUTHORS_SPIN) if rules.spin_rule else world.scenario
    authors = ArenaWorld(sc)
    chosen = authors.situations(key + situation)[0]
    crowd = Crowd(authors, start_poses(authors, chosen, key + situation, rules),
                  np.full(authors.vehicles, NETWORK), int(chosen.seed),
                  respawn_at_start=rules.respawn_at_start,
                  blame_all_after_respawn=rules.blame_all_after_respawn)
    learners = []
    for v in range(authors.vehicles):
        rng = np.random.default_rng([sc.seed, situation, v])
        population = authors.spec.in_source_layout(ga.initial_population(
            rng, sc.ga.population_size, authors.spec.chromosome_length, sc.ga.init_range))
        learners.append(VehicleGA(population, rng))
    online = OnlineLearning(learners, sc.ga, share_elites=True,
                            elite_count=sc.ga.elite_count, finish_steps=FINISH_STEPS,
                            breed_from_best=rules.breed_from_best)
    genes = np.stack([learner.current for learner in learners])
    learnt = []
    limit = ablation.authors_seconds if rules.until_finished else ablation.seconds
    while len(learnt) * SECONDS < limit:
        learnt.append(crowd.run(SECONDS, genes, online))
        if rules.until_finished and all(g.finished or g.generation >= AUTHORS_GENERATIONS
                                        for g in learners):
            break
    after = crowd.run(SECONDS, online.evolved_controllers(), check_spins=True)
    return learnt, after, online, len(learnt) * SECONDS


def frozen_arm(world: ArenaWorld, situation: int, evolved: np.ndarray, spans: int, key: int
               ) -> tuple[list, object]:
    """Each vehicle a distinct chromosome of the evolved population (vehicle v its row v), no
    learning, over the learning's spans and the one after."""
    crowd, _ = situation_crowd(world, situation, np.full(world.vehicles, NETWORK), key)
    genes = evolved[np.arange(world.vehicles) % len(evolved)].copy()
    runs = [crowd.run(SECONDS, genes, check_spins=True) for _ in range(spans + 1)]
    return runs[:-1], runs[-1]


def situation_arms(world: ArenaWorld, situation: int, winner: np.ndarray,
                   evolved: np.ndarray, ablation: Ablation, key: int = ABLATION_KEY,
                   shared: dict | None = None) -> tuple[list[dict], list[dict]]:
    """One situation's every arm: a row per arm (its first span, spans 2–11 and the span
    after learning; the initial drivers and the winner over their first span and that one;
    its learners' medians) and a row per arm and span of the learning. ``winner`` (G,) and
    ``evolved`` (N, G) in the source layout; ``shared`` keeps the strategy-free arms' results
    (``SHARED``) for the situation's other strategies."""
    shared = {} if shared is None else shared
    spans = round(ablation.seconds / SECONDS)
    crowd, genes = situation_crowd(world, situation, key=key)
    initial = [crowd.run(SECONDS, genes) for _ in range(spans + 1)]
    broadcast = _broadcast(world, winner, situation, key, periods=spans + 1)
    others = {"initial_first": initial[0].collision_rate,
              "initial_after": initial[-1].collision_rate,
              "winner_first": broadcast[0].collision_rate,
              "winner_after": broadcast[-1].collision_rate,
              "winner_after_spins": broadcast[-1].spin_rate}
    rows, windows = [], []
    for start, stopping in ARMS:
        if (start, stopping) in shared:
            row, learnt_rates = shared[start, stopping]
        else:
            if start == "authors":
                learnt, after, online, seconds = authors_arm(world, situation, ablation, key)
            elif stopping == "frozen":
                (learnt, after), online, seconds = (frozen_arm(world, situation, evolved, spans,
                                                               key), None, ablation.seconds)
            else:
                learning = replace(LEARNING, learning_s=ablation.seconds, start_population=start,
                                   **STOPPINGS[stopping])
                arena, online, learnt = learn_together(world, situation, winner, evolved,
                                                       learning, key)
                after = arena.run(SECONDS, online.evolved_controllers(), check_spins=True)
                seconds = ablation.seconds
            row = _row(start, stopping, learnt, after, online, seconds)
            learnt_rates = [run.collision_rate for run in learnt]
            if (start, stopping) in SHARED:
                shared[start, stopping] = row, learnt_rates
        rows.append(row | others)
        windows += [{"start_population": start, "stopping": stopping,
                     "window_start_s": span * SECONDS, "collisions_per_vehicle_s": rate}
                    for span, rate in enumerate(learnt_rates)]
    return rows, windows


def ablation_table(situations: pd.DataFrame, level: float = LEVEL) -> pd.DataFrame:
    """Per strategy and arm: the mean rates, each contrast's paired difference (``after``
    minus it) and its interval, simultaneous over every row and contrast (Bonferroni), and
    the reduction against the first span (the paper's figure)."""
    rng = np.random.default_rng(0)
    groups = situations.groupby(["strategy", "start_population", "stopping"], sort=False)
    family_level = 1 - (1 - level) / (groups.ngroups * len(CONTRASTS))
    rows = []
    for (strategy, start, stopping), group in groups:
        row = {"strategy": strategy, "start_population": start, "stopping": stopping,
               "situations": len(group)}
        row |= {column: round(group[column].mean(), 5)
                for column in ("after", *CONTRASTS)}
        first = group["first_span"].mean()
        row["reduction_vs_first_span"] = (round(1 - group["after"].mean() / first, 3)
                                          if first > 0 else float("nan"))
        for contrast in CONTRASTS:
            name = f"after_minus_{contrast}"
            differences = (group["after"] - group[contrast]).to_numpy()
            low, high = bootstrap_interval(differences, rng, DRAWS, family_level)
            row |= {name: round(differences.mean(), 5), f"{name}_low": round(low, 5),
                    f"{name}_high": round(high, 5)}
        row |= {"generations_bred": group["generations_bred"].median(),
                "finished_share": round(group["finished_share"].mean(), 3),
                "learning_s": group["learning_s"].median()}
        rows.append(row)
    return pd.DataFrame(rows)


def t_interval_counts(situations: pd.DataFrame, contrast: str, level: float = LEVEL
                      ) -> tuple[int, int]:
    """How many (strategy, arm) rows have the mean of ``after`` − ``contrast`` below and
    above 0 by Student-t intervals at the table's simultaneous level instead of the
    bootstrap's: a check on percentile intervals from 20 situations at a Bonferroni level. A
    shared arm (:data:`SHARED`) against its own spans is one measurement, counted once."""
    groups = situations.groupby(["strategy", "start_population", "stopping"], sort=False)
    family_level = 1 - (1 - level) / (groups.ngroups * len(CONTRASTS))
    first = situations["strategy"].min()
    below = above = 0
    for (strategy, start, stopping), group in groups:
        if (start, stopping) in SHARED and contrast in OWN and strategy != first:
            continue
        low, high = t_interval((group["after"] - group[contrast]).to_numpy(), family_level)
        below += high < 0
        above += low > 0
    return int(below), int(above)


FACTOR_OUTCOMES = {"after": "the rate after learning",
                   "after_minus_first_span": "the change from the first span",
                   "after_minus_early_spans": "the change from spans 2–11"}


def factor_effects(situations: pd.DataFrame, level: float = LEVEL) -> pd.DataFrame:
    """Each choice's effect in the 2 × 2 (start population × cap or finishing rule) on each of
    ``FACTOR_OUTCOMES``: the mean over strategies and the other choice of (outcome with the
    authors' option) − (outcome with ours), paired by situation, with its interval,
    simultaneous over the choices and outcomes (Bonferroni). Against the initial drivers or
    the winner driving on, an effect is its effect on the rate after learning: those arms
    are the same in every arm of a situation."""
    rng = np.random.default_rng(1)
    factors = {"start_population": ("random", "evolved"), "stopping": ("finish", "cap")}
    square = situations[situations["start_population"].isin(STARTS)
                        & situations["stopping"].isin(list(STOPPINGS))]
    square = square.assign(after_minus_first_span=square["after"] - square["first_span"],
                           after_minus_early_spans=square["after"] - square["early_spans"])
    family_level = 1 - (1 - level) / (len(factors) * len(FACTOR_OUTCOMES))
    rows = []
    for factor, (authors, ours) in factors.items():
        other = "stopping" if factor == "start_population" else "start_population"
        for outcome in FACTOR_OUTCOMES:
            wide = square.pivot_table(index=["strategy", "situation", other], columns=factor,
                                      values=outcome)
            effect = (wide[authors] - wide[ours]).groupby(level="situation").mean()
            low, high = bootstrap_interval(effect.to_numpy(), rng, DRAWS, family_level)
            rows.append({"factor": factor, "authors_option": authors, "our_option": ours,
                         "outcome": outcome, "effect": round(float(effect.mean()), 5),
                         "effect_low": round(low, 5), "effect_high": round(high, 5)})
    return pd.DataFrame(rows)


def draw(curve: pd.DataFrame, table: pd.DataFrame, path: Path) -> None:
    """Per strategy: every arm's learning curve, and the span after learning (dots) beside
    the winner driving on and its first span (dashed and dotted)."""
    strategies = sorted(curve["strategy"].unique())
    figure, axes = plt.subplots(1, len(strategies), figsize=(4 * len(strategies), 4.2),
                                sharey=True, squeeze=False)
    for ax, strategy in zip(axes[0], strategies, strict=True):
        rows = curve[curve["strategy"] == strategy]
        mine = table[table["strategy"] == strategy]
        for color, (start, stopping) in enumerate(ARMS):
            arm = rows[(rows["start_population"] == start) & (rows["stopping"] == stopping)]
            after = mine[(mine["start_population"] == start) & (mine["stopping"] == stopping)]
            label = "the authors' set-up" if start == "authors" else f"{start}, {stopping}"
            ax.plot(arm["window_start_s"] / 60, arm["collisions_per_vehicle_s"],
                    color=f"C{color}", linewidth=1, label=label)
            # at the median end of its learning (the authors' set-up ends when all finish)
            ax.plot((after["learning_s"] + SECONDS) / 60, after["after"], "o",
                    color=f"C{color}")
        ax.axhline(mine["winner_after"].iloc[0], color="k", linestyle="--", linewidth=1,
                   label="winner driving on")
        ax.axhline(mine["winner_first"].iloc[0], color="k", linestyle=":", linewidth=1,
                   label="winner, first span (Table 3)")
        ax.set_yscale("symlog", linthresh=0.01)
        ax.set_title(f"strategy {strategy}", fontsize=10)
        ax.set_xlabel("simulated minutes (dots: the span after learning,\nat the median "
                      "end of the learning; later spans: fewer situations)", fontsize=8)
    axes[0, 0].set_ylabel("collisions per vehicle-second")
    axes[0, 0].legend(fontsize=7)
    figure.suptitle("Table 4's ablation: start population × stopping rule, frozen evolved "
                    f"drivers, the authors' set-up; arena, mean of the situations, {SECONDS:g} s"
                    " spans")
    figure.tight_layout()
    save_figure(figure, path)


def measure(out: Path, ablation: Ablation, progress: bool = False) -> pd.DataFrame:
    """Every strategy's situations of every arm, written under ``out``:
    ``table4_ablation_situations.csv``, ``table4_ablation.csv``,
    ``table4_ablation_factors.csv``, ``table4_ablation_learning.csv`` and the plot."""
    try:
        inputs = saved_inputs(out)
    except FileNotFoundError as error:
        raise InputError(f"{error.filename} is missing: Table 4's ablation starts from the "
                         "controllers Tables 3–4 saved (run table3,table4 first)",
                         key="--only") from error
    rows, windows = [], []
    shared = {situation: {} for situation in range(ablation.situations)}
    for strategy, (winner, population) in inputs.items():
        world = ArenaWorld(shipped_scenario(ARENA.name(strategy)))
        winner_genes = world.spec.in_source_layout(winner)[0]
        evolved = world.spec.in_source_layout(population)
        started = time.perf_counter()
        for situation in tqdm(range(ablation.situations), desc=f"ablation strategy {strategy}",
                              unit="situation", disable=not progress, leave=False,
                              file=terminal()):
            each, spans = situation_arms(world, situation, winner_genes, evolved, ablation,
                                         shared=shared[situation])
            label = {"strategy": strategy, "situation": situation}
            rows += [label | row for row in each]
            windows += [label | window for window in spans]
        tqdm.write(f"ablation strategy {strategy}: {time.perf_counter() - started:.0f} s",
                   file=terminal())
    situations = pd.DataFrame(rows)
    table = ablation_table(situations)
    curve = pd.DataFrame(windows).groupby(
        ["strategy", "start_population", "stopping", "window_start_s"], as_index=False,
        sort=False)["collisions_per_vehicle_s"].mean().round(5)
    write_csv(out / "table4_ablation_situations.csv", situations.round(5))
    write_csv(out / "table4_ablation.csv", table)
    write_csv(out / "table4_ablation_factors.csv", factor_effects(situations))
    write_csv(out / "table4_ablation_learning.csv", curve)
    draw(curve, table, out / "table4_ablation.png")
    return table


def table4_ablation_lines(study: Study) -> list[str]:
    """The summary's line, from the tables the study wrote: per arm, its mean reduction
    against the paper's baseline (the initial drivers' first span) and against its own first
    span, and the measurements whose interval is below or above 0 for each contrast (a shared
    arm against its own spans is one); each choice's effect on the rate after learning."""
    table = pd.read_csv(study.out / "table4_ablation.csv")
    factors = pd.read_csv(study.out / "table4_ablation_factors.csv")
    situations = pd.read_csv(study.out / "table4_ablation_situations.csv")
    parts = []
    for (start, stopping), arm in table.groupby(["start_population", "stopping"], sort=False):
        means = _arm(situations, start, stopping).groupby("strategy").mean(numeric_only=True)
        counts = ", ".join(
            f"vs {contrast.replace('_', ' ')} "
            f"{int((rows[f'after_minus_{contrast}_high'] < 0).sum())} below / "
            f"{int((rows[f'after_minus_{contrast}_low'] > 0).sum())} above of {len(rows)}"
            for contrast in CONTRASTS
            for rows in [arm.head(1) if (start, stopping) in SHARED and contrast in OWN
                         else arm])
        parts.append(f"{start}, {stopping}: mean reduction vs the initial drivers' first span "
                     f"{mean_reduction(means, 'after', 'initial_first'):.0%}, vs its own "
                     f"first span {arm['reduction_vs_first_span'].mean():.0%}; {counts}")
    return ["table4_ablation (measurements with the simultaneous "
            f"{LEVEL:.0%} interval below / above 0): " + "; ".join(parts)
            + "; " + carrier(factors)]


def _arm(situations: pd.DataFrame, start: str, stopping: str) -> pd.DataFrame:
    return situations[(situations["start_population"] == start)
                      & (situations["stopping"] == stopping)]


def idle_arms(table: pd.DataFrame) -> list[tuple[str, str]]:
    """The learning arms (start population, stopping) of ``table4_ablation.csv`` whose
    learners bred no generation (median 0 in every strategy): their change from the first span
    is not breeding's."""
    learning = table[table["stopping"] != "frozen"]
    bred = learning.groupby(["start_population", "stopping"], sort=False)["generations_bred"]
    return [arm for arm, generations in bred if (generations == 0).all()]


def carrier(factors: pd.DataFrame, outcome: str = "after") -> str:
    """Each choice's effect on ``outcome`` (:data:`FACTOR_OUTCOMES`), in words chosen from
    its interval's sign."""
    words = []
    for row in factors[factors["outcome"] == outcome].itertuples():
        what = FACTOR_OUTCOMES[outcome]
        side = (f"raises {what}" if row.effect_low > 0 else f"lowers {what}"
                if row.effect_high < 0 else "its interval spans 0")
        words.append(f"{row.factor} {row.authors_option} instead of {row.our_option}: "
                     f"{row.effect:+.4f} per vehicle-second ({row.effect_low:+.4f} to "
                     f"{row.effect_high:+.4f}), {side}")
    return "; ".join(words)


def table4_ablation(study: Study) -> list[str]:
    """Table 4's ablation from the controllers Tables 3–4 saved in the study's folder."""
    measure(study.out, study.settings(ABLATION), study.progress)
    return table4_ablation_lines(study)


def facts(folder: Path) -> dict:
    """Facts (docs/_generate/README.md) of Table 4's ablation in a reproduce folder: per
    contrast, the rows below and above 0 by Student-t intervals at the table's simultaneous
    level (:func:`t_interval_counts`, over ``table4_ablation_situations.csv``), and the arms
    whose learners bred no generation (:func:`idle_arms`, over ``table4_ablation.csv``)."""
    situations = pd.read_csv(folder / "table4_ablation_situations.csv")
    counts = {contrast: t_interval_counts(situations, contrast) for contrast in CONTRASTS}
    curve = pd.read_csv(folder / "table4_ablation_learning.csv")
    arms = situations.groupby(["start_population", "stopping"], sort=False)
    return {"t_intervals": [{"contrast": contrast, "below": below, "above": above}
                            for contrast, (below, above) in counts.items()],
            "against_initial": [
                {"start_population": start, "stopping": stopping,
                 "reduction": mean_reduction(arm.groupby("strategy").mean(numeric_only=True),
                                             "after", "initial_first"),
                 **dict(zip(("low", "high"), reduction_interval(
                     arm, "after", np.random.default_rng(0), "initial_first"), strict=True))}
                for (start, stopping), arm in arms],
            "learners_vs_frozen": paired_by_strategy(
                _arm(situations, "evolved", "cap").set_index(["strategy", "situation"])
                .assign(frozen=_arm(situations, "evolved", "frozen")
                        .set_index(["strategy", "situation"])["after"]).reset_index(),
                "after", "frozen"),
            "curve_ends": [{"start_population": start, "stopping": stopping, "strategy": int(s),
                            "last_tenth": curve_ends(rows, "collisions_per_vehicle_s")[1]}
                           for (start, stopping, s), rows in curve.groupby(
                               ["start_population", "stopping", "strategy"], sort=False)],
            "idle_arms": [{"start_population": start, "stopping": stopping} for start, stopping
                          in idle_arms(pd.read_csv(folder / "table4_ablation.csv"))]}
