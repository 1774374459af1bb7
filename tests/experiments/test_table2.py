"""Table 2's incremental evolution (paper §5.4.1)."""

from dataclasses import replace
from pathlib import Path

import pandas as pd

from enn_traffic.experiments import choosing, families, table2
from enn_traffic.experiments.study import Study


def test_table2_evolves_a_wider_network_than_table1():
    """Table 2's one controller must hold every strategy's skill: its worlds are built with the
    family's incremental hidden layer, Table 1's with the scenarios' own (Figure 1's count)."""

    incremental = families.ARENA.incremental()
    (hidden,) = families.ARENA.incremental_hidden
    assert families.ARENA.scenario(2).network.hidden == [3] and hidden != 3
    # (19 beams + bias) x hidden + (hidden + bias) x 2 outputs
    study = Study(Path("unused"))
    assert families.strategy_world(study, incremental, 2, 1).spec.chromosome_length == (
        20 * hidden + (hidden + 1) * 2)
    assert families.strategy_world(study, families.ARENA, 2, 1).spec.chromosome_length == (
        20 * 3 + 4 * 2)


# The arena family on a small budget: short lives, a small GA, few situations.
SMALL_ARENA = replace(families.ARENA, quick={
    **families.ARENA.quick, "incremental_seeds": (1, 2), "test_situations": 4,
    "recheck_situations": 4,
    "ga": {"population_size": 16, "generations": 4, "elite_count": 2},
    "scenario_overrides": {"episode": {"max_steps": 300}}})


def test_table2_reports_the_evolution_whose_last_controller_does_best_on_validation(tmp_path):
    """One incremental evolution per seed; table2.csv is the one whose last controller's worst
    strategy does best on validation traffic, table2_runs.csv holds them all."""

    study = Study(tmp_path, quick=True, progress=False)
    table2.table2(study, SMALL_ARENA)
    runs = pd.read_csv(tmp_path / "table2_runs.csv")
    family = study.settings(SMALL_ARENA).incremental()
    assert sorted(runs["seed"].unique()) == list(family.incremental_seeds) == [1, 2]
    worst = {}
    for seed in family.incremental_seeds:
        last = tmp_path / "runs" / "incremental" / f"seed{seed}" / "iteration4"
        chosen = choosing.pick(study, family, choosing.candidates(last), family.strategies)
        worst[seed] = choosing.validation(study, family, chosen, family.strategies,
                                          family.recheck_situations).min()
    assert worst[1] != worst[2]  # the two evolutions are told apart
    best = max(worst, key=worst.get)
    expected = runs[runs["seed"] == best].drop(columns="seed").reset_index(drop=True)
    pd.testing.assert_frame_equal(pd.read_csv(tmp_path / "table2.csv"), expected)
    # the controller behind the table is committed with it and evaluates (issue 26)
    import subprocess
    import sys

    from enn_traffic.runs.controller import Controller

    path = tmp_path / "controllers" / "table2" / "last_iteration.npz"
    saved = Controller.load(path)
    assert saved.layer_sizes == (19, *family.incremental_hidden, 2)
    assert round(saved.fitness, 1) == expected["average"].iloc[-1]
    scenario = families.ARENA.scenario(4).source
    result = subprocess.run([sys.executable, "-m", "enn_traffic", "evaluate", str(path),
                             str(scenario), "--quiet"], capture_output=True, text=True)
    assert result.returncode == 0, result.stderr
