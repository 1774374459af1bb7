"""Fig. 11 (paper §5.3): learning curves among each traffic strategy, one run per seed."""

from __future__ import annotations

import numpy as np
import pandas as pd

from enn_traffic.core.io import write_csv
from enn_traffic.experiments.choosing import held_out
from enn_traffic.experiments.families import ARENA, Family, family_runs, title
from enn_traffic.experiments.study import Study
from enn_traffic.report.figures import fig11_figure


def fig11(study: Study, family: Family = ARENA) -> list[str]:
    """Learning curves, one run per seed and strategy, one panel per strategy: each
    generation's best training fitness (solid) and the same chromosome on test traffic
    (dashed)."""
    family = study.settings(family)
    out = study.out / family.folder
    rows = []
    runs_by_strategy = family_runs(study, family)
    scores = {}
    for strategy, runs in runs_by_strategy.items():
        for seed, table in runs.items():
            scores[strategy, seed] = held_out(study, family, strategy, seed)
            rows.append(run_row(strategy, seed, table, scores[strategy, seed]))
    fig11_figure(runs_by_strategy, scores, {s: title(family, s) for s in family.strategies},
                 f"Fig. 11 ({family.label}): the learner among traffic, "
                 f"{len(family.seeds)} runs per strategy\nsolid: each generation's best "
                 f"fitness; dashed: the same chromosome on {family.test_situations} test "
                 "situations", out / "fig11.png")
    write_csv(out / "fig11.csv", pd.DataFrame(rows))
    return fig11_lines(study, family)


def fig11_lines(study: Study, family: Family = ARENA) -> list[str]:
    """The summary's Fig. 11 line, from the ``fig11.csv`` the study wrote."""
    family = study.settings(family)
    table = pd.read_csv(study.out / family.folder / "fig11.csv")
    return [summary_line(table, f"{family.folder}/fig11" if family.folder else "fig11")]


def run_row(strategy: int, seed: int, table: pd.DataFrame, on_test: np.ndarray | None
            ) -> dict:
    """A run's row of fig11.csv from its generations table and each generation's best on
    test traffic (None: not measured). A rise is the mean of the last 5 generations over the
    first generation's (at least 1 step)."""
    best, mean = table["best_fitness"], table["mean_fitness"]
    on_test = np.full(len(table), np.nan) if on_test is None else np.asarray(on_test)
    return {
        "strategy": strategy, "seed": seed, "generations": len(table),
        "first_best": best.iloc[0], "last_best": best.iloc[-1],
        "last5_mean_best": best.tail(5).mean(), "max_best": best.max(),
        "rise": best.tail(5).mean() / max(best.iloc[0], 1.0),
        "first_mean": mean.iloc[0], "last5_mean_mean": mean.tail(5).mean(),
        "mean_rise": mean.tail(5).mean() / max(mean.iloc[0], 1.0),
        "first_held_out": on_test[0], "last5_mean_held_out": on_test[-5:].mean(),
        "held_out_rise": on_test[-5:].mean() / max(on_test[0], 1.0),
    }  # fmt: skip


def summary_line(table: pd.DataFrame, label: str) -> str:
    """The summary's Fig. 11 line: each strategy's median rise over its runs."""
    rise = table.groupby("strategy")[["rise", "mean_rise", "held_out_rise"]].median()
    return (f"{label}: best fitness, mean of the last 5 generations over the first generation's "
            "(median of the runs): "
            + ", ".join(f"strategy {s}: {r.rise:.1f}x" for s, r in rise.iterrows())
            + "; population mean fitness: "
            + ", ".join(f"{r.mean_rise:.1f}x" for _, r in rise.iterrows())
            + "; each generation's best on test traffic: "
            + ", ".join(f"{r.held_out_rise:.1f}x" for _, r in rise.iterrows()))
