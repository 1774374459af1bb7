"""Table 1 and Fig. 12 (paper §5.3): each strategy's controller deployed among every
strategy's traffic."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from enn_traffic.core.io import write_csv
from enn_traffic.experiments.choosing import fitness_on_test_traffic, specialists
from enn_traffic.experiments.common import save_controller
from enn_traffic.experiments.families import ARENA, Family, strategy_world
from enn_traffic.experiments.study import Study
from enn_traffic.report.figures import fig12_figure, specialist_paths
from enn_traffic.runs.evaluate import EVALUATION_KEY


def _draw_specialists(study: Study, family: Family, controllers: dict[int, np.ndarray], path: Path,
                      steps: int = 400) -> None:
    """Table 1 as paths: each strategy's chosen controller among each strategy's traffic, the
    first test situation."""
    traces, walls = {}, {}
    for deployed in family.strategies:
        world = strategy_world(study, family, deployed)
        walls[deployed] = world.track.walls
        for trained in family.strategies:
            traces[trained, deployed], _ = world.trace(controllers[trained], EVALUATION_KEY,
                                                       max_steps=steps)
    specialist_paths(traces, walls, family.strategies, steps, path)


def table1(study: Study, family: Family = ARENA) -> list[str]:
    """Train on each strategy, deploy on each (Table 1), and the colour map (Fig. 12)."""
    family = study.settings(family)
    root, out = study.out, study.out / family.folder
    controllers = specialists(study, family)
    matrix = np.array([[fitness_on_test_traffic(study, family, controllers[trained], deployed)
                        for deployed in family.strategies] for trained in family.strategies])
    for index, strategy in enumerate(family.strategies):
        save_controller(root, (Path(family.folder) / "table1" / f"strategy{strategy}").as_posix(),
                        family.scenario(strategy), controllers[strategy], matrix[index, index])
    table = pd.DataFrame(matrix.round(1), columns=[f"deploy_{s}" for s in family.strategies])
    table.insert(0, "training_strategy", family.strategies)
    write_csv(out / "table1.csv", table)
    fig12_figure(matrix, family.strategies, out / "fig12.png")
    _draw_specialists(study, family, controllers,
                      out / ("arena_paths.png" if family.names == ARENA.names else "paths.png"))
    return table1_lines(study, family)


def table1_lines(study: Study, family: Family = ARENA) -> list[str]:
    """The summary's Table 1 line, from the ``table1.csv`` the study wrote."""
    family = study.settings(family)
    matrix = pd.read_csv(study.out / family.folder / "table1.csv").drop(
        columns="training_strategy").to_numpy()
    return [summary_line(matrix, f"{family.folder}/table1" if family.folder else "table1")]


def diagonal_pattern(matrix: np.ndarray) -> tuple[float, float, int]:
    """The paper's Table 1 pattern, a diagonal (trained and deployed on the same strategy)
    above the rest of its row: the diagonal's mean, the rest's mean, and the rows where the
    diagonal entry is above every other of its row."""
    size = len(matrix)
    diagonal = np.diag(matrix)
    off = matrix[~np.eye(size, dtype=bool)]
    rows_ok = sum(diagonal[i] > np.delete(matrix[i], i).max() for i in range(size))
    return float(diagonal.mean()), float(off.mean()), int(rows_ok)


def summary_line(matrix: np.ndarray, label: str) -> str:
    """The summary's Table 1 line (:func:`diagonal_pattern`)."""
    own, rest, rows_ok = diagonal_pattern(matrix)
    return (f"{label}: mean diagonal {own:.0f}, mean off-diagonal {rest:.0f} "
            f"(ratio {own / rest:.2f}; paper 4.9); diagonal above the rest "
            f"of its row in {rows_ok} of {len(matrix)} rows (paper: 4 of 4)")


def facts(folder: Path) -> dict:
    """Facts (docs/_generate/README.md): how much one lifetime says, from the committed Table 1
    controllers' lives on traffic seed 5000 (``table1_seed5000.csv``, the README's
    ``evaluate`` command): the lowest and highest standard deviation of an entry's lifetimes
    (fitness, steps), and what that gives as the standard error of an entry's mean on Fig.
    11's test situations and on Table 1's (``ARENA.test_situations``,
    ``ARENA.table_situations``)."""
    lives = pd.read_csv(folder / "table1_seed5000.csv")
    spread = lives.groupby(["controller", "scenario"])["fitness"].std()
    low, high = float(spread.min()), float(spread.max())
    return {"lifetime_std": {"low": round(low, 3), "high": round(high, 3)},
            "standard_error": [{"situations": n, "low": round(low / np.sqrt(n), 3),
                                "high": round(high / np.sqrt(n), 3)}
                               for n in (ARENA.test_situations, ARENA.table_situations)]}
