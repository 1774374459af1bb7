"""What the crowds measure and how it is summed up: the records of a situation's arms, the
learning curve and its first and last tenth, Table 4's paired differences, the mean reduction
of the rate with its bootstrap interval, and the facts the documents state from them (the
arena's and the SUMO families' alike)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

# Table 4's arms over the span after learning, and the column each is compared with
ARMS = {"population": "each vehicle's evolved controller",
        "initial_after": "the initial drivers driving on",
        "winner_after": "the winner driving on", "reranked": "the re-ranked controllers"}


CONTRASTS = [("population", "initial_after"), ("population", "winner_after"),
             ("population", "reranked")]


@dataclass
class SituationResult:
    """One situation of Tables 3–4: the rates (the columns of ``simultaneous_situations.csv``),
    every arm's rate in each span of the learning (``windows``), each learner's counts, each
    vehicle's controller after learning (world layout) and the paths drawn."""

    rates: dict[str, float]
    windows: list[dict[str, float]]
    learners: list[dict[str, int]]
    controllers: np.ndarray
    traces: tuple
    cost: dict | None = None  # a SUMO crowd's: its wall time, and each arm's (crowd_cost.csv)


@dataclass
class Measured:
    """Every strategy's situations of Tables 3–4, their learning windows and learners."""

    situations: pd.DataFrame  # strategy, situation, one column per rate
    windows: pd.DataFrame  # strategy, situation, window_start_s, one column per arm
    learners: pd.DataFrame  # strategy, situation, learner, generations_bred, lives, ...


def learning_curve(windows: pd.DataFrame) -> pd.DataFrame:
    """Per strategy and span of the learning: every arm's collisions per vehicle-second,
    averaged over the situations (``collisions_per_vehicle_s``: the learners')."""
    curve = windows.groupby(["strategy", "window_start_s"], as_index=False)[
        ["learning", "initial_drivers", "winner_driving_on"]].mean()
    return curve.rename(columns={"learning": "collisions_per_vehicle_s"}).round(5)


LEARNING_ARMS = ["learning", "initial_drivers", "winner_driving_on"]  # columns of the windows


def learning_ends(windows: pd.DataFrame) -> pd.DataFrame:
    """Per strategy and situation: each arm's mean rate over the first and over the last
    tenth of the learning's spans (``ARM_first``, ``ARM_last``), so that whether the learning
    curve rises can be read with an interval paired by situation
    (``table4_learning_ends.csv``)."""
    rows = []
    for (strategy, situation), group in windows.groupby(["strategy", "situation"]):
        spans = group.sort_values("window_start_s")
        tenth = max(1, len(spans) // 10)
        row = {"strategy": strategy, "situation": situation}
        for arm in LEARNING_ARMS:
            row |= {f"{arm}_first": spans[arm].head(tenth).mean(),
                    f"{arm}_last": spans[arm].tail(tenth).mean()}
        rows.append(row)
    return pd.DataFrame(rows).round(6)


def trend(ends: pd.DataFrame, arm: str = "learning", level: float = 0.9
          ) -> tuple[float, float, float]:
    """The mean change of ``arm``'s rate from the first to the last tenth of the learning
    over every situation of ``ends`` (:func:`learning_ends`), with its ``level`` interval
    (pairs drawn again)."""
    change = (ends[f"{arm}_last"] - ends[f"{arm}_first"]).to_numpy()
    low, high = paired_interval(change, np.zeros_like(change), np.random.default_rng(0),
                                level=level)
    return float(change.mean()), low, high


def direction(low: float, high: float, up: str = "rises", down: str = "falls",
              neither: str = "moves neither way (its interval spans 0)") -> str:
    """The word an interval's sign allows: ``up`` above 0, ``down`` below, else
    ``neither``."""
    return up if low > 0 else down if high < 0 else neither


def curve_ends(curve: pd.DataFrame, column: str) -> tuple[float, float]:
    """``column``'s mean over the first and over the last tenth of the learning's spans (of
    one strategy's curve, or of every strategy's together)."""
    spans = curve.groupby("window_start_s")[column].mean().sort_index()
    tenth = max(1, len(spans) // 10)
    return float(spans.head(tenth).mean()), float(spans.tail(tenth).mean())


def paired_interval(after: np.ndarray, before: np.ndarray, rng: np.random.Generator,
                    draws: int = 2000, level: float = 0.9) -> tuple[float, float]:
    """The central ``level`` interval of the mean difference ``after - before`` when the
    situations (pairs) are drawn again with replacement (bootstrap)."""
    differences = np.asarray(after, dtype=np.float64) - np.asarray(before, dtype=np.float64)
    means = differences[rng.integers(0, len(differences), (draws, len(differences)))].mean(1)
    low, high = np.quantile(means, [(1 - level) / 2, (1 + level) / 2])
    return float(low), float(high)


def table4_comparisons(situations: pd.DataFrame,
                       arms: tuple[str, ...] = ("initial_after", "population", "winner_after",
                                                "reranked"),
                       contrasts: list[tuple[str, str]] = CONTRASTS, level: float = 0.9
                       ) -> pd.DataFrame:
    """Per strategy, Table 4's ``arms`` over the span after learning and the paired
    differences of ``contrasts`` with their ``level`` bootstrap intervals over the
    situations."""
    rng = np.random.default_rng(0)
    rows = []
    for strategy, group in situations.groupby("strategy"):
        row = {"strategy": strategy}  # the initial drivers first, then after learning
        row |= {f"{arm}_collisions_per_s": round(group[arm].mean(), 4) for arm in arms}
        for after, before in contrasts:
            low, high = paired_interval(group[after].to_numpy(), group[before].to_numpy(), rng,
                                        level=level)
            name = f"{after}_minus_{before}"
            row |= {name: round((group[after] - group[before]).mean(), 4),
                    f"{name}_low": round(low, 4), f"{name}_high": round(high, 4)}
        rows.append(row)
    return pd.DataFrame(rows)


def rates_table(measured: pd.DataFrame, after: str, before: str = "initial") -> pd.DataFrame:
    """Table 3 or 4 from the strategies' mean rates (``measured``: one row per strategy):
    collisions per second per vehicle of ``before`` and ``after``."""
    return pd.DataFrame({"strategy": measured["strategy"],
                         "initial_collisions_per_s": measured[before].round(4),
                         "after_collisions_per_s": measured[after].round(4)})


def strategy_means(situations: pd.DataFrame) -> pd.DataFrame:
    """Every rate column's mean over each strategy's situations."""
    return situations.drop(columns="situation").groupby("strategy", as_index=False).mean()


def mean_reduction(rates: pd.DataFrame, after: str, before: str = "initial") -> float:
    """The mean over the strategies of 1 − ``after`` / ``before`` (columns of
    ``simultaneous.csv``): how much fewer collisions, strategy by strategy."""
    return float((1 - rates[after] / rates[before]).mean())


def reduction_interval(situations: pd.DataFrame, after: str, rng: np.random.Generator,
                       before: str = "initial", draws: int = 2000, level: float = 0.9
                       ) -> tuple[float, float]:
    """How far the mean reduction over the strategies (1 − after / before, each strategy's
    rates averaged over its situations) moves with the situations: its central ``level``
    interval when each strategy's situations are drawn again with replacement (bootstrap,
    the same draw for both columns: paired)."""
    groups = [group for _, group in situations.groupby("strategy")]
    reductions = np.zeros(draws)
    for group in groups:
        first, later = group[before].to_numpy(), group[after].to_numpy()
        picks = rng.integers(0, len(group), (draws, len(group)))
        reductions += 1 - later[picks].mean(axis=1) / first[picks].mean(axis=1)
    reductions /= len(groups)
    low, high = np.quantile(reductions, [(1 - level) / 2, (1 + level) / 2])
    return float(low), float(high)


# The arms' columns of table4_learning.csv, whose first and last tenth the documents state
CURVE_COLUMNS = ["collisions_per_vehicle_s", "initial_drivers", "winner_driving_on"]


# The mean reductions (after, before) the documents state with their intervals
def paired_by_strategy(situations: pd.DataFrame, after: str, before: str,
                       level: float = 0.9) -> list[dict]:
    """Per strategy, the mean of ``after`` − ``before`` over its situations (paired) and its
    bootstrap interval, simultaneous over the strategies (Bonferroni, ``level`` for all)."""
    groups = situations.groupby("strategy")
    family = 1 - (1 - level) / groups.ngroups
    rng = np.random.default_rng(0)
    rows = []
    for strategy, group in groups:
        low, high = paired_interval(group[after], group[before], rng, 20000, family)
        rows.append({"strategy": int(strategy),
                     "difference": float((group[after] - group[before]).mean()),
                     "low": low, "high": high})
    return rows


REDUCTIONS = [("winner", "initial"), ("population", "initial_after"), ("population", "initial"),
              ("winner_after", "initial_after")]


def curve_facts(curve: pd.DataFrame) -> dict:
    """Each arm's first and last tenth of the learning (:func:`curve_ends`) in a learning
    curve (``table4_learning.csv``), per strategy and over every strategy together."""
    def ends(rows: pd.DataFrame) -> dict:
        return {column: dict(zip(("first", "last"), curve_ends(rows, column), strict=True))
                for column in CURVE_COLUMNS}

    return {"strategies": [{"strategy": int(strategy)} | ends(rows)
                           for strategy, rows in curve.groupby("strategy")],
            "all": ends(curve)}


def trend_facts(ends: pd.DataFrame) -> dict:
    """The learners' :func:`trend` over ``table4_learning_ends.csv``: the mean change from the
    first to the last tenth of the learning and its 90% interval over the situations."""
    change, low, high = trend(ends)
    return {"change": change, "low": low, "high": high}
