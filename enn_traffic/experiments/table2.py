"""Table 2 (paper §5.4.1): incremental evolution over the four traffic strategies, each
iteration's controller on every strategy's test traffic."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from enn_traffic.core.io import write_csv
from enn_traffic.experiments.choosing import fitness_on_test_traffic
from enn_traffic.experiments.common import save_controller
from enn_traffic.experiments.families import ARENA, Family
from enn_traffic.experiments.incremental import Iteration, incremental_evolution
from enn_traffic.experiments.study import Study


def _rows(study: Study, family: Family, seed: int, iterations: list[Iteration]
          ) -> tuple[list[dict], float]:
    """A row of test fitness per iteration, and the worst strategy of the last iteration's
    controller on validation traffic."""
    rows = []
    for number, iteration in enumerate(iterations, start=1):
        row = {"seed": seed, "iteration": number, "generations": iteration.generations,
               "reached_threshold": iteration.accepted}
        for strategy in family.strategies:
            row[f"strategy_{strategy}"] = (
                fitness_on_test_traffic(study, family, iteration.chosen, strategy)
                if strategy in iteration.included else np.nan)
        row["average"] = float(np.nanmean([row[f"strategy_{s}"] for s in iteration.included]))
        rows.append(row)
    return rows, iterations[-1].worst


def table2(study: Study, family: Family = ARENA) -> list[str]:
    """Incremental evolution: add a strategy each time the fitness passes 80% of the accepted
    fitness; the fitness is averaged over the strategies included so far (§5.4.1). One
    evolution per seed of ``incremental_seeds``; Table 2 is the one whose last controller's
    worst strategy does best on validation traffic, as Table 1 chooses among its seeds' runs."""
    family = study.settings(family).incremental()
    root, out = study.out, study.out / family.folder
    evolutions = {seed: incremental_evolution(study, family,
                                              out / "runs" / "incremental" / f"seed{seed}", seed)
                  for seed in family.incremental_seeds}
    chains = {seed: _rows(study, family, seed, iterations)
              for seed, iterations in evolutions.items()}
    seed = max(chains, key=lambda s: chains[s][1])  # the first of equals, as argmax
    last_row = chains[seed][0][-1]
    save_controller(root, (Path(family.folder) / "table2" / "last_iteration").as_posix(),
                    family.scenario(family.strategies[0]), evolutions[seed][-1].chosen,
                    last_row["average"])
    every = pd.DataFrame([row for rows, _ in chains.values() for row in rows])
    write_csv(out / "table2_runs.csv", every.round(1))
    table = every[every["seed"] == seed].drop(columns="seed").reset_index(drop=True)
    write_csv(out / "table2.csv", table.round(1))
    return table2_lines(study, family)


def table2_lines(study: Study, family: Family = ARENA) -> list[str]:
    """The summary's Table 2 line, from the ``table2.csv`` (the chosen seed's evolution) and
    ``table2_runs.csv`` (every seed's) the study wrote."""
    family = study.settings(family).incremental()
    threshold = family.threshold
    every = pd.read_csv(study.out / family.folder / "table2_runs.csv")
    table = pd.read_csv(study.out / family.folder / "table2.csv")
    seed = next(s for s, rows in every.groupby("seed")  # the seed whose evolution it is
                if rows.drop(columns="seed").reset_index(drop=True).equals(table))
    last = table.iloc[-1]
    kept = all(last[f"strategy_{s}"] > threshold for s in family.strategies)
    ends = every.groupby("seed").last()[[f"strategy_{s}" for s in family.strategies]].min(axis=1)
    label = f"{family.folder}/table2" if family.folder else "table2"
    return [f"{label}: average fitness {table['average'].iloc[0]:.0f} after iteration 1, "
            f"{last['average']:.0f} after iteration {int(last['iteration'])} "
            f"({last['average'] / table['average'].iloc[0]:.0%} of the first; paper 96%); "
            f"every strategy above the {threshold:.0f}-step threshold at the end: {kept} "
            f"(seed {seed} of {every['seed'].nunique()}, chosen on validation traffic; each "
            "seed's worst "
            "strategy at the end: " + ", ".join(f"{v:.0f}" for v in ends) + ")"]
