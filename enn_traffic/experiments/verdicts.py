"""A verdict for every experiment of the paper: the paper's claim, ours as one figure with
its interval, and one word from a fixed scale (docs/results.md, "Verdicts").

Each claim is read as a comparison: our figure lies on the paper's ``side`` (``above`` or
``below``) of a ``null`` — what no effect gives (no seed learns, no fall, no specialist
ahead), or, for a claim that something holds within a bound (Table 2's 96%), that bound —
and, where the paper reports a figure of its own, near that figure. Every fall is taken from
the paper's baseline, its initial column: our initial drivers' first span. The word follows
from our 90% interval by one rule (:func:`verdict`):

- **reproduced**: the interval lies on the paper's side of the null and, where the paper gives
  a figure, holds it;
- **in direction only**: the interval lies on the paper's side of the null, the paper's figure
  outside it;
- **not reproduced**: the interval reaches the null or lies beyond it;
- **beyond the paper**: the paper makes no such claim.

A claim that a run of the paper did something (it learnt, it drove back and forth) has the
paper's figure 1, every run doing it, and the null 0: our share of seeds that do, with its
Clopper–Pearson interval, is reproduced when every seed does, in direction only when some do.
Intervals: Clopper–Pearson for shares of seeds; Student's t over seeds for a per-seed figure
(t over the logarithms for a ratio); the crowds' bootstrap over situations
(:func:`~enn_traffic.experiments.crowds.stats.reduction_interval`); Table 1's ratio by a
bootstrap of its test situations, paired across the controllers deployed on a strategy.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pandas as pd

from enn_traffic.experiments.crowds.stats import mean_reduction, reduction_interval
from enn_traffic.report.paper import (
    PAPER_REDUCTION,
    PAPER_TABLE1,
    PAPER_TABLE2,
    PAPER_TABLE3,
    PAPER_TABLE4,
)
from enn_traffic.report.stats import t_interval

LEVEL = 0.9
VERDICTS = ("reproduced", "in direction only", "not reproduced", "beyond the paper")


def verdict(low: float, high: float, null: float | None, side: str | None,
            figure: float | None = None) -> str:
    """The word for an interval (``low``, ``high``) against a claim: our figure ``side``
    (``above`` / ``below``) of ``null``, and near the paper's ``figure`` where it gives one;
    no ``side``: no claim of the paper's."""
    if side is None:
        return "beyond the paper"
    on_side = low > null if side == "above" else high < null
    if not on_side:
        return "not reproduced"
    if figure is None or low <= figure <= high:
        return "reproduced"
    return "in direction only"


def row(name: str, value: float, low: float, high: float, null: float | None,
        side: str | None, figure: float | None = None, **details) -> dict:
    """One verdict row: the figure, its interval, the claim and the word."""
    return {"name": name, "value": float(value), "low": float(low), "high": float(high),
            "null": null, "side": side, "figure": figure,
            "verdict": verdict(low, high, null, side, figure), **details}


def share_of_seeds(name: str, done: pd.Series, **details) -> dict:
    """A claim that a run of the paper did something: the share of our seeds that did
    (``done``, one boolean per seed), with its Clopper–Pearson interval."""
    from scipy import stats

    k, n = int(done.sum()), len(done)
    interval = stats.binomtest(k, n).proportion_ci(LEVEL, method="exact")
    return row(name, k / n, interval.low, interval.high, 0.0, "above", 1.0, done=k,
               seeds=n, **details)


def paper_table1_ratio() -> float:
    """The paper's Table 1: the mean of the diagonal over the mean of the rest."""
    table = np.array(PAPER_TABLE1, dtype=float)
    off = ~np.eye(len(table), dtype=bool)
    return float(np.diag(table).mean() / table[off].mean())


def table1_ratio(episodes: pd.DataFrame, rng: np.random.Generator, draws: int = 2000
                 ) -> tuple[float, float, float, int]:
    """Table 1's diagonal mean over its off-diagonal mean, from each controller's lifetimes
    on each strategy's test situations (``evaluate``'s table), its bootstrap interval (each
    strategy's situations drawn again, the same draw for every controller) and the number
    of strategies on which their own specialist lives longest."""
    wide = episodes.pivot_table(index=["scenario", "situation"], columns="controller",
                                values="fitness")
    controllers = sorted(wide.columns)
    scenarios = sorted(wide.index.get_level_values("scenario").unique())
    blocks = [wide.loc[s, controllers].to_numpy() for s in scenarios]  # (situations, C)

    def ratio(means: np.ndarray) -> float:  # means[deployed, trained]
        off = ~np.eye(len(means), dtype=bool)
        return float(np.diag(means).mean() / means[off].mean())

    means = np.stack([block.mean(axis=0) for block in blocks])
    value = ratio(means)
    ratios = np.empty(draws)
    for d in range(draws):
        ratios[d] = ratio(np.stack([block[rng.integers(0, len(block), len(block))].mean(axis=0)
                                    for block in blocks]))
    low, high = np.quantile(ratios, [(1 - LEVEL) / 2, (1 + LEVEL) / 2])
    tops = int((means.argmax(axis=1) == np.arange(len(means))).sum())
    return value, float(low), float(high), tops


def crowd_reduction(name: str, situations: pd.DataFrame, after: str, figure: float,
                    before: str = "initial", **details) -> dict:
    """A crowd's mean reduction from ``before`` (by default the initial drivers' first span,
    the paper's initial column) to ``after``, with its bootstrap interval over the
    situations."""
    means = situations.groupby("strategy").mean(numeric_only=True)
    low, high = reduction_interval(situations, after, np.random.default_rng(0), before)
    return row(name, mean_reduction(means, after, before), low, high, 0.0, "above", figure,
               **details)


def fig7(paper: Path) -> dict:
    runs = pd.read_csv(paper / "fig7.csv")
    reached = runs["reached_B_generation"]
    return share_of_seeds("fig7", reached.notna() & (reached < runs["generations"]),
                          first=int(reached.min()), last=int(reached.max()))


def fig8(paper: Path) -> dict:
    runs = pd.read_csv(paper / "fig8.csv")
    return share_of_seeds("fig8", runs["capped_generation"].notna(),
                          untrained=int((runs["reached_B_generation"] == 0).sum()))


def fig9(paper: Path) -> dict:
    table = pd.read_csv(paper / "fig9.csv")
    runs = pd.read_csv(paper / "fig9_runs.csv")
    three = runs[(runs["beams"] == 3) & (runs["span_deg"] == 180)]
    others = table[table["span_deg"] == 180][["beams", "runs", "runs_accepted"]]
    return share_of_seeds("fig9", three["generations_to_accepted"].notna(),
                          others=others.to_dict("records"))


ONE_TRACK = ("navigation_narrow", "navigation_wide")  # trained as the paper, on one track


def generalization(paper: Path) -> dict:
    table = pd.read_csv(paper / "generalization.csv")
    test = table[table["tracks"] == "test"]
    shares = test.groupby(["trained_on", "seed"])["capped"].mean()
    one = shares.loc[list(ONE_TRACK)].to_numpy()
    low, high = t_interval(one, LEVEL)
    return row("generalization", one.mean(), low, high, 0.0, "above", 1.0,
               tracks=int(test["track"].nunique()), runs=len(one),
               mixed=float(shares.loc["navigation_mixed"].mean()))


def fig11(paper: Path) -> dict:
    runs = pd.read_csv(paper / "fig11.csv")
    logs = np.log(runs["held_out_rise"].to_numpy())
    low, high = t_interval(logs, LEVEL)
    return row("fig11", math.exp(logs.mean()), math.exp(low), math.exp(high), 1.0, "above",
               runs=len(runs))


def table1(paper: Path) -> dict:
    episodes = pd.read_csv(paper / "table1_seed5000.csv")  # evaluate's table: every life
    value, low, high, tops = table1_ratio(episodes, np.random.default_rng(0))
    return row("table1", value, low, high, 1.0, "above", round(paper_table1_ratio(), 3),
               situations=int(episodes["situation"].nunique()), tops=tops,
               rows=int(episodes["controller"].nunique()))


def table2(paper: Path) -> dict:
    runs = pd.read_csv(paper / "table2_runs.csv")
    ends = runs.groupby("seed")["average"].agg(["first", "last"])
    logs = np.log((ends["last"] / ends["first"]).to_numpy())
    low, high = t_interval(logs, LEVEL)
    paper_ratio = float(np.mean(PAPER_TABLE2[-1]) / PAPER_TABLE2[0][0])
    return row("table2", math.exp(logs.mean()), math.exp(low), math.exp(high),
               round(paper_ratio, 3), "above", seeds=len(logs))


def table3(paper: Path) -> dict:
    return crowd_reduction("table3", pd.read_csv(paper / "simultaneous_situations.csv"),
                           "winner", round(PAPER_REDUCTION["table3"], 3))


def table4(paper: Path) -> dict:
    situations = pd.read_csv(paper / "simultaneous_situations.csv")
    means = situations.groupby("strategy").mean(numeric_only=True)
    low, high = reduction_interval(situations, "population", np.random.default_rng(0),
                                   "initial_after")
    return crowd_reduction("table4", situations, "population",
                           round(PAPER_REDUCTION["table4"], 3),
                           later=mean_reduction(means, "population", "initial_after"),
                           later_low=low, later_high=high)


def table4_vs_table3(paper: Path) -> dict:
    """Table 4 below Table 3 (paper: in every strategy): the fall from the winner driving every
    vehicle over its first span to the learners after learning; the paper's figure, its mean
    over the strategies of 1 − Table 4's rate after / Table 3's."""
    situations = pd.read_csv(paper / "simultaneous_situations.csv")
    figure = float(np.mean([1 - four[1] / three[1]
                            for three, four in zip(PAPER_TABLE3, PAPER_TABLE4, strict=True)]))
    means = situations.groupby("strategy").mean(numeric_only=True)
    low, high = reduction_interval(situations, "population", np.random.default_rng(0),
                                   "paper_winner")
    return crowd_reduction("table4_vs_table3", situations, "population", round(figure, 3),
                           before="winner", paper_way=mean_reduction(means, "population",
                                                                     "paper_winner"),
                           paper_way_low=low, paper_way_high=high)


def authors_setup(paper: Path) -> dict:
    """Table 4 in the authors' set-up (the ablation's ``authors`` arm): its fall from the
    paper's baseline, and from its own first span, where its cars are their own initial
    drivers (``authors_rules.csv``, fresh keys)."""
    situations = pd.read_csv(paper / "table4_ablation_situations.csv")
    arm = situations[situations["start_population"] == "authors"]
    own = pd.read_csv(paper / "authors_rules.csv").set_index("variant").loc["all three"]
    return crowd_reduction("authors_setup", arm.rename(columns={"initial_first": "initial"}),
                           "after", round(PAPER_REDUCTION["table4"], 3),
                           own_fall=float(own["fall"]))


def lane_keeping(paper: Path) -> dict:
    table = pd.read_csv(paper / "lane_keeping.csv")
    own = table[(table["trained_on"] == "lane_keeping") & (table["noise_m"] == 0)
                & table["road"].str.startswith("training")]
    mixed = table[(table["trained_on"] == "lane_keeping_mixed") & (table["noise_m"] == 0)]
    every = mixed.groupby("seed")["kept_whole_episode"].all()
    return share_of_seeds("lane_keeping", own.groupby("seed")["kept_whole_episode"].all(),
                          roads=int(mixed["road"].nunique()), mixed_seeds=len(every),
                          mixed_every_road=int(every.sum()))


def family(name: str, folder: Path) -> dict:
    return crowd_reduction(name, pd.read_csv(folder / "crowd_situations.csv"), "population",
                           round(PAPER_REDUCTION["table4"], 3))


ROWS = {"fig7": fig7, "fig8": fig8, "fig9": fig9, "generalization": generalization,
        "fig11": fig11, "table1": table1, "table2": table2, "table3": table3,
        "table4": table4, "table4_vs_table3": table4_vs_table3,
        "authors_setup": authors_setup, "lane_keeping": lane_keeping,
        "sumo": lambda paper: family("sumo", paper / "sumo"),
        "city": lambda paper: family("city", paper / "city")}


def baseline_facts(folder: Path) -> dict:
    """Facts: the GA against gradient RL's verdict row (beyond the paper) in a ``baseline``
    folder: a method's mean test fitness minus the GA's (PPO's where it ran) at the smallest
    budget both ran, under the first scenario's rule (the paper's), with its Welch t
    interval."""
    table = pd.read_csv(folder / "comparison_differences.csv")
    if table.empty:  # the GA alone: no method to set beside it
        raise FileNotFoundError(folder / "comparison_differences.csv")
    first = table[(table["scenario"] == table["scenario"].iloc[0])
                  & (table["budget_steps"] == table["ga_budget_steps"])].dropna(
                      subset=["minus_ga_low"])
    if first.empty:  # no method ran at a budget of the GA's, or too few seeds for an interval
        raise FileNotFoundError(folder / "comparison_differences.csv")
    first = first.sort_values("budget_steps", kind="stable")
    ppo = first[first["method"] == "PPO"]
    chosen = (ppo if len(ppo) else first).iloc[0]
    return row("gradient_rl", chosen["minus_ga"], chosen["minus_ga_low"],
               chosen["minus_ga_high"], None, None, method=chosen["method"],
               scenario=chosen["scenario"],
               budget_steps=int(chosen["budget_steps"]), seeds=int(chosen["seeds"]),
               ga_seeds=int(chosen["ga_seeds"]))


def paper_facts(folder: Path) -> dict:
    """Facts (docs/_generate/README.md): the verdict rows of the experiments whose tables a
    reproduce ``folder`` holds, in the order of :data:`ROWS`."""
    rows = []
    for make in ROWS.values():
        try:
            rows.append(make(folder))
        except FileNotFoundError:  # an experiment not run into this folder
            continue
    if not rows:
        raise FileNotFoundError(folder)
    return {"rows": rows, "level": LEVEL, "verdicts": list(VERDICTS)}
