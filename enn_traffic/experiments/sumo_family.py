"""The SUMO families' experiments (docs/sumo.md): Fig. 11 and Tables 1–4 on SUMO traffic, and
each strategy's Table 1 controller, trained on replayed traffic, on the same test situations
with SUMO's drivers reacting to it (closed loop). ``sumo``: our ring and grid networks;
``city``: the Cologne morning under four SUMO driver models."""

from __future__ import annotations

from pathlib import Path

import pandas as pd

from enn_traffic.deploy import EVALUATION_KEY
from enn_traffic.experiments.choosing import trained_controllers
from enn_traffic.experiments.fig11 import fig11
from enn_traffic.experiments.protocol import CITY, SUMO, Family, strategy_world
from enn_traffic.experiments.sumo_crowds import sumo_tables
from enn_traffic.experiments.table1 import table1
from enn_traffic.experiments.table2 import table2
from enn_traffic.io import write_csv
from enn_traffic.worlds import make_world


def replay_against_closed_loop(out: Path, quick: bool = False, progress: bool = True,
                               family: Family = SUMO) -> list[str]:
    """Each strategy's Table 1 controller (trained on replayed traffic) on the same test
    situations with the traffic replayed and in closed loop: lifetimes side by side."""
    controllers = trained_controllers(out, quick, progress, family)
    rows = []
    for strategy in family.strategies:
        test = strategy_world(family.settings(quick), strategy).scenario
        lifetimes = {}
        for mode in ("replay", "closed-loop"):
            world = make_world(test.with_overrides(traffic={"mode": mode}))
            lifetimes[mode] = world.evaluate(controllers[strategy][None, :], EVALUATION_KEY)
        for episode in range(test.traffic.episodes):
            rows.append({"strategy": strategy, "episode": episode,
                         "replay_steps": int(lifetimes["replay"].steps[0, episode]),
                         "closed_loop_steps": int(lifetimes["closed-loop"].steps[0, episode])})
    table = pd.DataFrame(rows)
    write_csv(out / family.folder / "closed_loop.csv", table)
    means = table.groupby("strategy")[["replay_steps", "closed_loop_steps"]].mean()
    pairs = ", ".join(f"strategy {s}: {r.replay_steps:.0f} vs {r.closed_loop_steps:.0f}"
                      for s, r in means.iterrows())
    return [f"{family.folder}/closed_loop: mean lifetime of each strategy's controller, replayed "
            f"vs closed loop: {pairs}"]


def family_experiments(family: Family, out: Path, quick: bool, progress: bool) -> list[str]:
    """Fig. 11 and Tables 1–4 over a SUMO family's strategies, and the replayed against the
    closed-loop lifetimes, into ``out/<family folder>/``."""
    return [*fig11(out, quick, progress, family), *table1(out, quick, progress, family),
            *table2(out, quick, progress, family),
            *replay_against_closed_loop(out, quick, progress, family),
            *sumo_tables(out, quick, progress, family)]


def sumo(out: Path, quick: bool = False, progress: bool = True) -> list[str]:
    """The SUMO family of our own networks (``sumo_strategy1..4``), into ``out/sumo/``."""
    return family_experiments(SUMO, out, quick, progress)


def city(out: Path, quick: bool = False, progress: bool = True) -> list[str]:
    """The city family (Cologne under four driver models), into ``out/city/``."""
    return family_experiments(CITY, out, quick, progress)
