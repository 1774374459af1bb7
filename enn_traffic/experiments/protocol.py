"""The protocol of the dynamic-traffic experiments (paper §5.3–5.4): families of traffic
strategies (four, as the paper's), the settings each experiment runs them with, and where each
run lives.

Three families of strategies run the same experiments: the arena's scripted strategies
(``scenarios/arena_strategy1..4``, into the reproduce folder), SUMO traffic on SUMO networks
of our own (``scenarios/sumo_strategy1..4``, into its ``sumo/`` subfolder), and the Cologne
city's traffic under four SUMO driver models (``scenarios/city_*``, into ``city/``)."""

from __future__ import annotations

from dataclasses import dataclass, replace
from functools import cache
from pathlib import Path

import pandas as pd

from enn_traffic.experiments.common import run_all
from enn_traffic.scenario import Scenario
from enn_traffic.shipped import shipped_scenario
from enn_traffic.sim.world import World
from enn_traffic.worlds import make_world


@dataclass(frozen=True)
class Family:
    """A set of traffic strategies (the shipped scenarios ``names``, strategy 1 first; the
    paper's families have four) and the experiment settings that go with it."""

    names: tuple[str, ...]
    folder: str  # subfolder of the reproduce folder ("" for the top)
    seeds: tuple[int, ...]
    test_episodes: int  # Fig. 11's test curves, and the first look at candidates
    recheck_episodes: int
    table_episodes: int  # the test situations of each entry of Tables 1 and 2
    accepted_fitness: float
    incremental_max_generations: int
    # Table 2's hidden layers (None: the scenarios' own): its one controller must hold every
    # strategy's skill, each of Table 1's only one (docs/results.md, "Why Table 2 evolves a
    # wider network")
    incremental_hidden: tuple[int, ...] | None = None
    incremental_seeds: tuple[int, ...] = (1,)  # Table 2's evolutions, one per GA seed
    hidden: tuple[int, ...] | None = None  # every scenario's hidden layers, when given
    quick: tuple = (("population_size", 40), ("generations", 12), ("elite_count", 4))
    # --quick: the first seeds, fewer test situations, and scenario overrides (section, items)
    quick_seeds: int = 2
    quick_test_episodes: int = 10
    quick_scenario: tuple = ()
    quick_mode: bool = False

    def name(self, strategy: int) -> str:
        return self.names[strategy - 1]

    @property
    def strategies(self) -> list[int]:
        """The strategies' numbers, 1 first."""
        return list(range(1, len(self.names) + 1))

    @property
    def label(self) -> str:
        """The scenarios in a few words: ``sumo_strategy1-4``, or their names."""
        prefix = self.names[0].removesuffix("1")
        if self.names == _numbered(prefix, len(self.names)):
            return f"{prefix}1-{len(self.names)}"
        return ", ".join(self.names)

    def settings(self, quick: bool) -> Family:
        """This family as ``--quick`` runs it, or unchanged."""
        if not quick or self.quick_mode:
            return self
        return replace(self, seeds=self.seeds[: self.quick_seeds],
                       incremental_seeds=self.incremental_seeds[: self.quick_seeds],
                       test_episodes=self.quick_test_episodes,
                       recheck_episodes=self.quick_test_episodes,
                       table_episodes=self.quick_test_episodes, quick_mode=True)

    def incremental(self) -> Family:
        """This family as Table 2 runs it: with the incremental network."""
        return replace(self, hidden=self.incremental_hidden)

    def overrides(self) -> dict:
        overrides = ({section: dict(items) for section, items in self.quick_scenario}
                     if self.quick_mode else {})
        if self.hidden is not None:
            overrides["network"] = {"hidden": list(self.hidden)}
        return overrides

    def scenario(self, strategy: int) -> Scenario:
        """A strategy's scenario, with the quick overrides in quick mode and the family's
        hidden layers if it sets them."""
        sc, overrides = shipped_scenario(self.name(strategy)), self.overrides()
        return sc.with_overrides(**overrides) if overrides else sc

    @property
    def threshold(self) -> float:
        """Table 2's acceptance threshold: 80% of the accepted fitness (§5.4.1)."""
        return 0.8 * self.accepted_fitness

    def ga(self) -> dict:
        """GA overrides: the small quick settings in quick mode."""
        return dict(self.quick) if self.quick_mode else {}


def _numbered(prefix: str, count: int = 4) -> tuple[str, ...]:
    return tuple(f"{prefix}{strategy}" for strategy in range(1, count + 1))


ARENA = Family(_numbered("arena_strategy"), "", (1, 2, 3, 4), test_episodes=40,
               recheck_episodes=200, table_episodes=200, accepted_fitness=750.0,
               incremental_max_generations=150,
               incremental_hidden=(6,), incremental_seeds=(1, 2, 3, 4))
SUMO = Family(_numbered("sumo_strategy"), "sumo", (1, 2), test_episodes=10, recheck_episodes=30,
              table_episodes=10, accepted_fitness=2000.0, incremental_max_generations=20,
              quick=(("population_size", 40), ("generations", 6), ("elite_count", 4)),
              quick_seeds=1, quick_test_episodes=3,
              quick_scenario=(("episode", (("max_steps", 1000),)),
                              ("traffic", (("warmup_s", 20.0),))))
# The Cologne morning (city_cologne3) and three SUMO driver models on it (docs/sumo.md, "City
# strategies"); a life is at most 1200 steps, so the accepted fitness is two thirds of it, as
# SUMO's 2000 of 3000.
CITY = replace(SUMO, names=("city_cologne3", "city_impatient", "city_stopgo", "city_rush"),
               folder="city", accepted_fitness=800.0,
               quick_scenario=(("episode", (("max_steps", 600),)),))


def run_dir(family: Family, out: Path, strategy: int, seed: int) -> Path:
    """Where a strategy's run of one seed lives in the (family's) output folder."""
    return out / "runs" / family.name(strategy) / f"seed{seed}"


def family_runs(family: Family, out: Path, progress: bool) -> dict[int, dict[int, pd.DataFrame]]:
    """Every strategy's runs, one per seed (all submitted at once, so on Ray they run side by
    side): ``{strategy: {seed: generations table}}``."""
    jobs = {}
    for strategy in family.strategies:
        base = family.scenario(strategy)
        for seed in family.seeds:
            jobs[strategy, seed] = (base.with_overrides(seed=seed, ga=family.ga()),
                                    run_dir(family, out, strategy, seed))
    tables = run_all(jobs, progress)
    return {strategy: {seed: tables[strategy, seed] for seed in family.seeds}
            for strategy in family.strategies}


def strategy_world(family: Family, strategy: int, episodes: int | None = None) -> World:
    """The world of a strategy with ``episodes`` traffic situations (``test_episodes`` unless
    given), built once for each count."""
    return _world(family, strategy, episodes or family.test_episodes)


@cache
def _world(family: Family, strategy: int, episodes: int) -> World:
    sc = family.scenario(strategy)
    return make_world(sc.with_overrides(traffic={"episodes": episodes}))


def title(family: Family, strategy: int) -> str:
    sc = family.scenario(strategy)
    kind = sc.traffic.strategy if family is ARENA else sc.description.rstrip(".")
    return f"strategy {strategy}: {kind}"
