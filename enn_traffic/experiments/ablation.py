"""Table 4 as an ablation (paper §5.5.2; issue 61): which procedural choice carries the pattern.

Table 4 differs from the authors' procedure in two choices (docs/departures.md, "Learning
while driving"): our learners start from the evolved population, theirs from random populations
(reference §7.1: their code cannot load an evolved one); our chromosome's trial ends at a
300-step life cap, theirs has no cap and a vehicle keeps a chromosome for good once a life with
it lasted 2000 steps (reference §7.5, ``GA.goodFitness``). This experiment crosses them —
start population {random, evolved} × stopping {cap, finish} — on the arena's four strategies,
on situations of their own (:data:`enn_traffic.keys.ABLATION_CROWD_TEST`, sealed, read once),
from the winners and evolved populations Tables 3–4 saved under ``controllers/``.

For every arm, the collisions per vehicle-second of the span after learning (each vehicle its
evolved controller) are set against (a) the arm's own first span of learning (the paper's
baseline: its Table 4 reports the learning's start and end), (b) the initial drivers driving on
and (c) the winner driving on, over the same span, paired by situation. The intervals are
paired bootstrap intervals over the situations, simultaneous for the whole table (Bonferroni:
90% for the family of every arm, strategy and contrast). ``table4_ablation_factors.csv`` gives
each choice's effect, the mean over strategies and the other choice, with its interval: the
choice whose effect is apart from 0 is the one that carries the pattern.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field, replace
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd
from tqdm import tqdm

from enn_traffic import keys
from enn_traffic.errors import InputError
from enn_traffic.experiments.protocol import ARENA, SUMO, Family
from enn_traffic.experiments.simultaneous import (
    LEARNING,
    SECONDS,
    _broadcast,
    learn_together,
    saved_inputs,
    situation_crowd,
)
from enn_traffic.experiments.study import Study
from enn_traffic.experiments.sumo_crowds import (
    SUMO_LEARNING,
    SumoLearning,
    saved_crowd_inputs,
    situation_result,
)
from enn_traffic.io import write_csv
from enn_traffic.progress import terminal
from enn_traffic.report.plots import save_figure
from enn_traffic.shipped import shipped_scenario
from enn_traffic.sim.arena import ArenaWorld

ABLATION_KEY = keys.ABLATION_CROWD_TEST.start
FINISH_STEPS = 2000  # reference §7.5: GA.goodFitness
STARTS = ("random", "evolved")
STOPPINGS = {"cap": {"life_cap_steps": LEARNING.life_cap_steps, "finish_steps": 0},
             "finish": {"life_cap_steps": 0, "finish_steps": FINISH_STEPS}}
# the span after learning against: (a) its own first span, (b), (c) the other arms driving on
CONTRASTS = {"first_span": "its own first span of learning",
             "initial_after": "the initial drivers driving on",
             "winner_after": "the winner driving on"}
LEVEL = 0.9  # for the whole family of intervals of a table


@dataclass(frozen=True)
class Ablation:
    """How long each arm learns, in how many situations per strategy, and what ``--quick``
    changes of them; Table 4's learning time (``simultaneous.LEARNING``) by default."""

    seconds: float = LEARNING.seconds
    situations: int = LEARNING.situations
    quick: dict = field(default_factory=lambda: {"seconds": 300.0, "situations": 2})


ABLATION = Ablation()


def arms() -> list[tuple[str, str]]:
    """(start population, stopping) of every arm."""
    return [(start, stopping) for start in STARTS for stopping in STOPPINGS]


def situation_arms(world: ArenaWorld, situation: int, winner: np.ndarray,
                   evolved: np.ndarray, ablation: Ablation, key: int = ABLATION_KEY
                   ) -> tuple[list[dict], list[dict]]:
    """One situation's every arm: a row per arm (the rates of its first span, of the span
    after learning and of the initial drivers and the winner over that span, and its learners'
    medians) and a row per arm and span of the learning. ``winner`` (G,) and ``evolved``
    (N, G) in the source layout."""
    spans = round(ablation.seconds / SECONDS)
    crowd, genes = situation_crowd(world, situation, key=key)
    initial = [crowd.run(SECONDS, genes) for _ in range(spans + 1)][-1]
    winner_after = _broadcast(world, winner, situation, key, periods=spans + 1)[-1]
    rows, windows = [], []
    for start, stopping in arms():
        learning = replace(LEARNING, seconds=ablation.seconds, start_population=start,
                           **STOPPINGS[stopping])
        arena, online, learnt = learn_together(world, situation, winner, evolved, learning,
                                               key)
        after = arena.run(SECONDS, online.evolved_controllers(), check_spins=True)
        learners = pd.DataFrame(online.learner_rows())
        label = {"start_population": start, "stopping": stopping}
        rows.append(label | {
            "first_span": learnt[0].collision_rate, "after": after.collision_rate,
            "after_spins": after.spin_rate, "initial_after": initial.collision_rate,
            "winner_after": winner_after.collision_rate,
            "generations_bred": float(learners["generations_bred"].median()),
            "finished_share": float(learners.get("finished", pd.Series([0])).mean())})
        windows += [label | {"window_start_s": span * SECONDS,
                             "collisions_per_vehicle_s": run.collision_rate}
                    for span, run in enumerate(learnt)]
    return rows, windows


def bootstrap_interval(differences: np.ndarray, rng: np.random.Generator, level: float,
                       draws: int = 20000) -> tuple[float, float]:
    """The central ``level`` interval of the mean of ``differences`` (pairs drawn again with
    replacement)."""
    differences = np.asarray(differences, dtype=np.float64)
    means = differences[rng.integers(0, len(differences), (draws, len(differences)))].mean(1)
    low, high = np.quantile(means, [(1 - level) / 2, (1 + level) / 2])
    return float(low), float(high)


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
                for column in ("first_span", "after", "initial_after", "winner_after")}
        first = group["first_span"].mean()
        row["reduction_vs_first_span"] = (round(1 - group["after"].mean() / first, 3)
                                          if first > 0 else float("nan"))
        for contrast in CONTRASTS:
            name = f"after_minus_{contrast}"
            differences = (group["after"] - group[contrast]).to_numpy()
            low, high = bootstrap_interval(differences, rng, family_level)
            row |= {name: round(differences.mean(), 5), f"{name}_low": round(low, 5),
                    f"{name}_high": round(high, 5)}
        row |= {"generations_bred": group["generations_bred"].median(),
                "finished_share": round(group["finished_share"].mean(), 3)}
        rows.append(row)
    return pd.DataFrame(rows)


def factor_effects(situations: pd.DataFrame, level: float = LEVEL) -> pd.DataFrame:
    """Each choice's effect on each contrast: the mean over strategies and the other choice
    of (contrast with the authors' option) − (contrast with ours), paired by situation, with
    its interval, simultaneous over the choices and contrasts (Bonferroni). Positive: the
    authors' option makes learning look worse by that contrast."""
    rng = np.random.default_rng(1)
    factors = {"start_population": ("random", "evolved"), "stopping": ("finish", "cap")}
    family_level = 1 - (1 - level) / (len(factors) * len(CONTRASTS))
    rows = []
    for factor, (authors, ours) in factors.items():
        other = "stopping" if factor == "start_population" else "start_population"
        keys_ = ["strategy", "situation", other]
        for contrast in CONTRASTS:
            value = situations.assign(d=situations["after"] - situations[contrast])
            wide = value.pivot_table(index=keys_, columns=factor, values="d")
            effect = (wide[authors] - wide[ours]).groupby(level="situation").mean()
            low, high = bootstrap_interval(effect.to_numpy(), rng, family_level)
            rows.append({"factor": factor, "authors_option": authors, "our_option": ours,
                         "contrast": f"after_minus_{contrast}",
                         "effect": round(float(effect.mean()), 5), "effect_low": round(low, 5),
                         "effect_high": round(high, 5)})
    return pd.DataFrame(rows)


def draw(curve: pd.DataFrame, table: pd.DataFrame, path: Path) -> None:
    """Per strategy: every arm's learning curve, and the span after learning (dots) beside
    the winner driving on (dashed)."""
    strategies = sorted(curve["strategy"].unique())
    figure, axes = plt.subplots(1, len(strategies), figsize=(4 * len(strategies), 3.8),
                                sharey=True, squeeze=False)
    for ax, strategy in zip(axes[0], strategies, strict=True):
        rows = curve[curve["strategy"] == strategy]
        end = rows["window_start_s"].max() / 60 + SECONDS / 60
        for color, (start, stopping) in enumerate(arms()):
            arm = rows[(rows["start_population"] == start) & (rows["stopping"] == stopping)]
            after = table[(table["strategy"] == strategy) & (table["start_population"] == start)
                          & (table["stopping"] == stopping)]
            ax.plot(arm["window_start_s"] / 60, arm["collisions_per_vehicle_s"],
                    color=f"C{color}", linewidth=1, label=f"start {start}, {stopping}")
            ax.plot([end], after["after"], "o", color=f"C{color}")
        winner = table[table["strategy"] == strategy]["winner_after"].iloc[0]
        ax.axhline(winner, color="k", linestyle="--", linewidth=1, label="winner driving on")
        ax.set_yscale("symlog", linthresh=0.01)
        ax.set_title(f"strategy {strategy}", fontsize=10)
        ax.set_xlabel("simulated minutes (dots: the span after learning)")
    axes[0, 0].set_ylabel("collisions per vehicle-second")
    axes[0, 0].legend(fontsize=7)
    figure.suptitle("Table 4's ablation: start population × stopping rule, arena, mean of the "
                    f"situations in {SECONDS:g} s spans")
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
    for strategy, (winner, population) in inputs.items():
        world = ArenaWorld(shipped_scenario(ARENA.name(strategy)))
        winner_genes = world.spec.in_source_layout(winner)[0]
        evolved = world.spec.in_source_layout(population)
        started = time.perf_counter()
        for situation in tqdm(range(ablation.situations), desc=f"ablation strategy {strategy}",
                              unit="situation", disable=not progress, leave=False,
                              file=terminal()):
            each, spans = situation_arms(world, situation, winner_genes, evolved, ablation)
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


def summary_lines(table: pd.DataFrame, factors: pd.DataFrame) -> list[str]:
    """The summary's line: per arm, the strategies whose interval is below or above 0 for
    each contrast, and the choice whose effect on the contrast with the winner is apart from
    0."""
    parts = []
    for (start, stopping), arm in table.groupby(["start_population", "stopping"], sort=False):
        counts = ", ".join(
            f"vs {contrast.replace('_', ' ')} "
            f"{int((arm[f'after_minus_{contrast}_high'] < 0).sum())} below / "
            f"{int((arm[f'after_minus_{contrast}_low'] > 0).sum())} above"
            for contrast in CONTRASTS)
        parts.append(f"start {start}, {stopping}: mean reduction vs its first span "
                     f"{arm['reduction_vs_first_span'].mean():.0%}; {counts}")
    return [f"table4_ablation (strategies of {len(table['strategy'].unique())} with the "
            f"simultaneous {LEVEL:.0%} interval below / above 0): " + "; ".join(parts)
            + "; " + carrier(factors)]


def carrier(factors: pd.DataFrame, contrast: str = "after_minus_winner_after") -> str:
    """Which choice's effect on ``contrast`` has its interval apart from 0, in words chosen
    from the interval's sign."""
    words = []
    for row in factors[factors["contrast"] == contrast].itertuples():
        side = ("raises the learners' rate against the winner" if row.effect_low > 0
                else "lowers the learners' rate against the winner" if row.effect_high < 0
                else "its interval spans 0")
        words.append(f"{row.factor} {row.authors_option} instead of {row.our_option}: "
                     f"{row.effect:+.4f} per vehicle-second ({row.effect_low:+.4f} to "
                     f"{row.effect_high:+.4f}), {side}")
    return "; ".join(words)


# One SUMO strategy: ours against the arm whose choice carries the arena's pattern (the
# start population, table4_ablation_factors.csv), on keys of its own in the ablation range.
SUMO_STRATEGY = 1
SUMO_ARMS = (("evolved", "cap"), ("random", "cap"))
SUMO_KEY = keys.ABLATION_CROWD_TEST.start + 1_000_000


def sumo_situations(out: Path, family: Family, learning: SumoLearning,
                    strategy: int = SUMO_STRATEGY, progress: bool = False) -> pd.DataFrame:
    """``SUMO_ARMS`` among the SUMO traffic of ``family``'s ``strategy``, from the winner
    and evolved population saved under ``out/controllers``: a row per situation and arm, the
    columns of ``table4_ablation_situations.csv``."""
    world, winner, evolved = saved_crowd_inputs(out, family)[strategy]
    stopping = {"cap": {"life_cap_steps": learning.life_cap_steps, "finish_steps": 0},
                "finish": {"life_cap_steps": 0, "finish_steps": FINISH_STEPS}}
    rows = []
    for situation in tqdm(range(learning.situations), desc=f"{family.folder} ablation",
                          unit="situation", disable=not progress, file=terminal()):
        for start, stop in SUMO_ARMS:
            arm = replace(learning, start_population=start, **stopping[stop])
            result = situation_result(world, winner, evolved, situation, arm, SUMO_KEY)
            learners = pd.DataFrame(result.learners)
            rows.append({"strategy": strategy, "situation": situation,
                         "start_population": start, "stopping": stop,
                         "first_span": result.windows[0]["learning"],
                         "after": result.rates["population"], "after_spins": float("nan"),
                         "initial_after": result.rates["initial_after"],
                         "winner_after": result.rates["winner_after"],
                         "generations_bred": float(learners["generations_bred"].median()),
                         "finished_share": float(learners.get("finished",
                                                              pd.Series([0])).mean())})
    return pd.DataFrame(rows)


def table4_ablation_sumo(study: Study) -> list[str]:
    """The arena ablation's deciding choice on one strategy of the SUMO family, from the
    controllers its Tables 3–4 saved: ``sumo/table4_ablation.csv`` and its situations."""
    family = study.settings(SUMO)
    try:
        situations = sumo_situations(study.out, family, study.settings(SUMO_LEARNING),
                                     progress=study.progress)
    except FileNotFoundError as error:
        raise InputError(f"{error.filename} is missing: the SUMO ablation starts from the "
                         "controllers the SUMO family saved (run sumo first)",
                         key="--only") from error
    folder = study.out / family.folder
    table = ablation_table(situations)
    write_csv(folder / "table4_ablation_situations.csv", situations.round(5))
    write_csv(folder / "table4_ablation.csv", table)
    words = []
    for row in table.to_dict("records"):
        words.append(f"start {row['start_population']}, {row['stopping']}: "
                     f"{row['first_span']:.3f} -> {row['after']:.3f}, against the winner "
                     f"{_interval_words(row, 'after_minus_winner_after')}")
    return [f"sumo/table4_ablation (strategy {SUMO_STRATEGY}, collisions per learner-second, "
            "first window -> window after learning): " + "; ".join(words)]


def _interval_words(row: dict, name: str) -> str:
    word = ("above" if row[f"{name}_low"] > 0 else "below" if row[f"{name}_high"] < 0
            else "not apart")
    return (f"{word} ({row[name]:+.4f}, {row[f'{name}_low']:+.4f} to "
            f"{row[f'{name}_high']:+.4f})")


def table4_ablation(study: Study) -> list[str]:
    """Table 4's ablation from the controllers Tables 3–4 saved in the study's folder."""
    table = measure(study.out, study.settings(ABLATION), study.progress)
    return summary_lines(table, pd.read_csv(study.out / "table4_ablation_factors.csv"))
