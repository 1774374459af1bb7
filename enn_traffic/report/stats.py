"""Intervals the result tables carry (docs/results.md): a claim is a measurement with one."""

from __future__ import annotations

import numpy as np


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
    covers poorly); a single value is its own interval."""
    from scipy import stats

    values = np.asarray(values, dtype=np.float64)
    if len(values) < 2:
        return float(values.mean()), float(values.mean())
    low, high = stats.t.interval(level, len(values) - 1, loc=values.mean(),
                                 scale=stats.sem(values))
    return float(low), float(high)
