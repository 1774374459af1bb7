"""The families of the dynamic-traffic experiments (paper §5.3–5.4): sets of traffic
strategies (four, as the paper's), the settings each experiment runs them with, and where each
run lives.

Three families of strategies run the same experiments: the arena's scripted strategies
(``scenarios/arena_strategy1..4``, into the reproduce folder), SUMO traffic on SUMO networks
of our own (``scenarios/sumo_strategy1..4``, into its ``sumo/`` subfolder), and the Cologne
city's traffic under four SUMO driver models (``scenarios/city_*``, into ``city/``)."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING

import pandas as pd

from enn_traffic.config import Scenario
from enn_traffic.config.shipped import shipped_scenario
from enn_traffic.sim.world import World

if TYPE_CHECKING:
    from enn_traffic.experiments.study import Study


@dataclass(frozen=True)
class Family:
    """A set of traffic strategies (the shipped scenarios ``names``, strategy 1 first; the
    paper's families have four) and the experiment settings that go with it."""

    names: tuple[str, ...]
    folder: str  # subfolder of the reproduce folder ("" for the top)
    seeds: tuple[int, ...]
    test_situations: int  # Fig. 11's test curves, and the first look at candidates
    recheck_situations: int
    table_situations: int  # the test situations of each entry of Tables 1 and 2
    accepted_fitness: float
    incremental_max_generations: int
    # Table 2's hidden layers (None: the scenarios' own): its one controller must hold every
    # strategy's skill, each of Table 1's only one (docs/results.md, "Why Table 2 evolves a
    # wider network")
    incremental_hidden: tuple[int, ...] | None = None
    incremental_seeds: tuple[int, ...] = (1,)  # Table 2's evolutions, one per GA seed
    hidden: tuple[int, ...] | None = None  # every scenario's hidden layers, when given
    ga: Mapping[str, object] = field(default_factory=dict)  # GA overrides of every run
    # scenario overrides of every strategy: section -> {key: value}
    scenario_overrides: Mapping[str, Mapping[str, object]] = field(default_factory=dict)
    quick: Mapping[str, object] = field(default_factory=dict)  # what --quick changes

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

    def incremental(self) -> Family:
        """This family as Table 2 runs it: with the incremental network."""
        return replace(self, hidden=self.incremental_hidden)

    def scenario(self, strategy: int, situations: int | None = None) -> Scenario:
        """A strategy's scenario, with the family's overrides and hidden layers if it sets
        them, and ``situations`` traffic situations if given."""
        overrides = {section: dict(items) for section, items in self.scenario_overrides.items()}
        if self.hidden is not None:
            overrides["network"] = {"hidden": list(self.hidden)}
        sc = shipped_scenario(self.name(strategy))
        sc = sc.with_overrides(**overrides) if overrides else sc
        return sc if situations is None else sc.with_overrides(traffic={"episodes": situations})

    @property
    def threshold(self) -> float:
        """Table 2's acceptance threshold: 80% of the accepted fitness (§5.4.1)."""
        return 0.8 * self.accepted_fitness


def _numbered(prefix: str, count: int = 4) -> tuple[str, ...]:
    return tuple(f"{prefix}{strategy}" for strategy in range(1, count + 1))


ARENA = Family(_numbered("arena_strategy"), "", (1, 2, 3, 4), test_situations=40,
               recheck_situations=200, table_situations=200, accepted_fitness=750.0,
               incremental_max_generations=150,
               incremental_hidden=(6,), incremental_seeds=(1, 2, 3, 4),
               quick={"seeds": (1, 2), "incremental_seeds": (1,), "test_situations": 10,
                      "recheck_situations": 10, "table_situations": 10,
                      "ga": {"population_size": 40, "generations": 12, "elite_count": 4}})
SUMO = Family(_numbered("sumo_strategy"), "sumo", (1, 2), test_situations=10, recheck_situations=30,
              table_situations=10, accepted_fitness=2000.0, incremental_max_generations=20,
              quick={"seeds": (1,), "incremental_seeds": (1,), "test_situations": 2,
                     "recheck_situations": 2, "table_situations": 2,
                     "ga": {"population_size": 40, "generations": 3, "elite_count": 4},
                     "scenario_overrides": {"episode": {"max_steps": 1000},
                                            "traffic": {"warmup_s": 20.0}}})
# The Cologne morning (city_cologne3) and three SUMO driver models on it (docs/sumo.md, "City
# strategies"); a life is at most 1200 steps, so the accepted fitness is two thirds of it, as
# SUMO's 2000 of 3000.
CITY = replace(SUMO, names=("city_cologne3", "city_impatient", "city_stopgo", "city_rush"),
               folder="city", accepted_fitness=800.0,
               quick={**SUMO.quick, "scenario_overrides": {"episode": {"max_steps": 600}}})


def run_dir(family: Family, out: Path, strategy: int, seed: int) -> Path:
    """Where a strategy's run of one seed lives in the (family's) output folder."""
    return out / "runs" / family.name(strategy) / f"seed{seed}"


def family_runs(study: Study, family: Family) -> dict[int, dict[int, pd.DataFrame]]:
    """Every strategy's runs, one per seed (all submitted at once, so on Ray they run side by
    side): ``{strategy: {seed: generations table}}``."""
    out = study.out / family.folder
    jobs = {}
    for strategy in family.strategies:
        base = family.scenario(strategy)
        for seed in family.seeds:
            jobs[strategy, seed] = (base.with_overrides(seed=seed, ga=dict(family.ga)),
                                    run_dir(family, out, strategy, seed))
    tables = study.run_all(jobs)
    return {strategy: {seed: tables[strategy, seed] for seed in family.seeds}
            for strategy in family.strategies}


def strategy_world(study: Study, family: Family, strategy: int, situations: int | None = None
                   ) -> World:
    """The world of a strategy with ``situations`` traffic situations (``test_situations`` unless
    given), built once per study."""
    return study.world(family.scenario(strategy, situations or family.test_situations))


def title(family: Family, strategy: int) -> str:
    sc = family.scenario(strategy)
    kind = sc.traffic.strategy if family.names == ARENA.names else sc.description.rstrip(".")
    return f"strategy {strategy}: {kind}"
