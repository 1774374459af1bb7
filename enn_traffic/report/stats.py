"""Intervals the result tables carry (docs/results.md): a claim is a measurement with one."""

from __future__ import annotations

import numpy as np
import pandas as pd


def bootstrap_interval(values: np.ndarray, rng: np.random.Generator, draws: int = 2000,
                       level: float = 0.9) -> tuple[float, float]:
    """The central ``level`` interval of the mean of ``values`` when they are drawn again
    with replacement (bootstrap)."""
    values = np.asarray(values, dtype=np.float64)
    means = values[rng.integers(0, len(values), (draws, len(values)))].mean(axis=1)
    low, high = np.quantile(means, [(1 - level) / 2, (1 + level) / 2])
    return float(low), float(high)


def t_interval(values: np.ndarray, level: float = 0.9) -> tuple[float, float]:
    """Student's t interval of the mean of a few values (seeds' scores: a bootstrap over 3–5
    covers poorly); a single value, or values without spread, are their own interval."""
    from scipy import stats

    values = np.asarray(values, dtype=np.float64)
    if len(values) < 2 or values.std() == 0:  # no spread (every seed at the cap, say)
        return float(values.mean()), float(values.mean())
    low, high = stats.t.interval(level, len(values) - 1, loc=values.mean(),
                                 scale=stats.sem(values))
    return float(low), float(high)


def welch_contrast(groups: list[np.ndarray], weights: list[float], level: float = 0.9
                   ) -> tuple[float, float, float]:
    """A weighted sum of independent groups' means (a difference of two differences, say)
    with its Welch–Satterthwaite t interval: (estimate, low, high). Groups without spread
    give a point; a group of one value has no spread to estimate (NaN interval)."""
    from scipy import stats

    groups = [np.asarray(group, dtype=np.float64) for group in groups]
    estimate = float(sum(w * group.mean() for w, group in zip(weights, groups, strict=True)))
    if min(len(group) for group in groups) < 2:
        return estimate, float("nan"), float("nan")
    parts = np.array([w * w * group.var(ddof=1) / len(group)
                      for w, group in zip(weights, groups, strict=True)])
    if parts.sum() == 0:
        return estimate, estimate, estimate
    freedom = parts.sum() ** 2 / sum(part ** 2 / (len(group) - 1)
                                     for part, group in zip(parts, groups, strict=True))
    half = stats.t.ppf((1 + level) / 2, freedom) * np.sqrt(parts.sum())
    return estimate, float(estimate - half), float(estimate + half)


def permutation_p(first: np.ndarray, second: np.ndarray) -> float:
    """Two-sided p-value of the difference of two groups' means under every reassignment of
    their values to the groups (exact: 184,756 for 10 against 10), which needs no normal
    shape: seeds' scores piled at a step cap, or without spread, are fine."""
    from scipy import stats

    first, second = (np.asarray(v, dtype=np.float64) for v in (first, second))
    if np.concatenate([first, second]).std() == 0:
        return 1.0
    result = stats.permutation_test(
        (first, second), lambda x, y, axis: x.mean(axis=axis) - y.mean(axis=axis),
        permutation_type="independent", vectorized=True, n_resamples=np.inf,
        alternative="two-sided")
    return float(result.pvalue)


def above_share(first: np.ndarray, second: np.ndarray) -> float:
    """The share of pairs (one value of each group) in which the first group's is higher,
    ties counting half: a difference that no rescaling of the scores changes."""
    first, second = (np.asarray(v, dtype=np.float64)[:, None] for v in (first, second))
    return float(((first > second.T) + 0.5 * (first == second.T)).mean())


def holm(p_values: pd.Series) -> pd.Series:
    """Holm's step-down adjustment of a family of p-values (missing ones left out of the
    family and missing in the result)."""
    known = p_values.dropna().sort_values()
    size = len(known)
    adjusted = np.maximum.accumulate((size - np.arange(size)) * known.to_numpy())
    return pd.Series(np.minimum(adjusted, 1.0), index=known.index).reindex(p_values.index)
