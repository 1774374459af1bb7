"""The SUMO families' experiments (docs/sumo.md): Fig. 11 and Tables 1–4 on SUMO traffic, and
each strategy's Table 1 controller, trained on replayed traffic, on the same test situations
with SUMO's drivers reacting to it (closed loop). ``sumo``: our ring and grid networks;
``city``: the Cologne morning under four SUMO driver models."""

from __future__ import annotations

import numpy as np
import pandas as pd

from enn_traffic.core.io import write_csv
from enn_traffic.experiments.choosing import specialists
from enn_traffic.experiments.crowds.sumo import crowd_lines, sumo_tables
from enn_traffic.experiments.families import CITY, SUMO, Family
from enn_traffic.experiments.fig11 import fig11, fig11_lines
from enn_traffic.experiments.study import Study
from enn_traffic.experiments.table1 import table1, table1_lines
from enn_traffic.experiments.table2 import table2, table2_lines
from enn_traffic.runs.evaluate import EVALUATION_KEY
from enn_traffic.sim.world import make_world


def replay_against_closed_loop(study: Study, family: Family = SUMO) -> list[str]:
    """Each strategy's Table 1 controller (trained on replayed traffic) on the same test
    situations with the traffic replayed and in closed loop: lifetimes side by side."""
    family = study.settings(family)
    table = closed_loop_table(family, specialists(study, family))
    write_csv(study.out / family.folder / "closed_loop.csv", table)
    return [closed_loop_line(table, family)]


def family_lines(study: Study, family: Family) -> list[str]:
    """A SUMO family's summary lines, from the tables the study wrote into its folder."""
    family = study.settings(family)
    table = pd.read_csv(study.out / family.folder / "closed_loop.csv")
    return [*fig11_lines(study, family), *table1_lines(study, family),
            *table2_lines(study, family), closed_loop_line(table, family),
            *crowd_lines(study.out / family.folder)]


def sumo_lines(study: Study) -> list[str]:
    """The SUMO family's summary lines (:func:`family_lines`)."""
    return family_lines(study, SUMO)


def city_lines(study: Study) -> list[str]:
    """The city family's summary lines (:func:`family_lines`)."""
    return family_lines(study, CITY)


def closed_loop_table(family: Family, controllers: dict[int, np.ndarray]) -> pd.DataFrame:
    """``closed_loop.csv``: every strategy's controller (world layout) on its test situations,
    the traffic replayed and in closed loop."""
    rows = []
    for strategy in family.strategies:
        test = family.scenario(strategy, family.test_situations)
        lifetimes = {}
        for mode in ("replay", "closed-loop"):
            world = make_world(test.with_overrides(traffic={"mode": mode}))
            lifetimes[mode] = world.evaluate(controllers[strategy][None, :], EVALUATION_KEY)
        for episode in range(test.traffic.episodes):
            rows.append({"strategy": strategy, "episode": episode,
                         "replay_steps": int(lifetimes["replay"].steps[0, episode]),
                         "closed_loop_steps": int(lifetimes["closed-loop"].steps[0, episode])})
    return pd.DataFrame(rows)


def closed_loop_line(table: pd.DataFrame, family: Family) -> str:
    """The summary line of ``closed_loop.csv``: each strategy's mean lifetimes."""
    means = table.groupby("strategy")[["replay_steps", "closed_loop_steps"]].mean()
    pairs = ", ".join(f"strategy {s}: {r.replay_steps:.0f} vs {r.closed_loop_steps:.0f}"
                      for s, r in means.iterrows())
    return (f"{family.folder}/closed_loop: mean lifetime of each strategy's controller, "
            f"replayed vs closed loop: {pairs}")


def family_experiments(study: Study, family: Family) -> list[str]:
    """Fig. 11 and Tables 1–4 over a SUMO family's strategies, and the replayed against the
    closed-loop lifetimes, into ``<study folder>/<family folder>/``."""
    fig11(study, family)
    table1(study, family)
    table2(study, family)
    replay_against_closed_loop(study, family)
    sumo_tables(study, family)
    return family_lines(study, family)


def sumo(study: Study) -> list[str]:
    """The SUMO family of our own networks (``sumo_strategy1..4``), into ``sumo/``."""
    return family_experiments(study, SUMO)


def city(study: Study) -> list[str]:
    """The city family (Cologne under four driver models), into ``city/``."""
    return family_experiments(study, CITY)
