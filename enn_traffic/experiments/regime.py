"""The paper's regime beside ours (§5.5, Tables 3–4's initial column; reference §7).

The paper counts 13.49–20.05 collisions per second among the arena's vehicles before learning;
the authors' code has no scripted drivers: all 8 cars learn at once from random populations of
200, each life a chromosome, and a car that crashes restarts at its own fixed start pose with
its next chromosome, with no check that the spot is free (reference §7.1–7.3). Our Tables 3–4
report responsible collisions per vehicle-second among scripted initial drivers, respawning at
a random free spot.

This experiment puts the two side by side in the paper's unit — collisions per second of all 8
vehicles together — on the situations Tables 3–4 measure (the first ``SECONDS``), moving from
ours to the authors' set-up one step at a time, so that each step's factor is measured:

1. ``initial drivers``: each strategy's scripted drivers (Table 3's initial column);
2. ``untrained networks``: every vehicle a fixed random network (genes drawn as the GA's first
   generation), respawning at a free spot;
3. ``... respawn at own start``: the authors' respawn;
4. ``... learning from scratch``: each vehicle learning from a random population of 200 with the
   shared elites (the authors' set-up);
5. ``... authors' spin rule``: 4.9 s within 8 m (reference §6.2) instead of our 30 s, 17 m.

Collisions and spins are counted apart; ``lives_lost_per_s`` is both (a spin also ends a life
in the authors' code). Written to ``regime.csv``, with the same rates in other time bases
(:func:`time_bases`: per step, per 100 steps), as the paper may have counted per step of
0.1 s rather than per second (a hypothesis about the paper's time base).
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from enn_traffic.config.shipped import shipped_scenario
from enn_traffic.core.io import write_csv
from enn_traffic.experiments.crowds.arena import LEARNING, SECONDS, SITUATION_KEY, situation_crowd
from enn_traffic.experiments.families import ARENA
from enn_traffic.experiments.study import Study
from enn_traffic.learning import ga
from enn_traffic.learning.online import OnlineLearning, VehicleGA
from enn_traffic.report.paper import PAPER_INITIAL
from enn_traffic.sim.arena import ArenaWorld
from enn_traffic.sim.crowd import Crowd
from enn_traffic.sim.strategies import NETWORK

AUTHORS_SPIN = {"spin_window": 49, "spin_variance": 64.0}  # reference §6.2
UNTRAINED = [  # (configuration, respawn at own start, learning, the authors' spin rule)
    ("untrained networks", False, False, False),
    ("untrained networks, respawn at own start", True, False, False),
    ("untrained learners from scratch, respawn at own start", True, True, False),
    ("untrained learners from scratch, respawn at own start, authors' spin rule", True, True,
     True),
]


TIME_BASES = {"step": 1, "100_steps": 100}  # the time bases beside seconds, in steps


def time_bases(lives_lost_per_s: np.ndarray, dt: float) -> dict[str, np.ndarray]:
    """Lives lost per second in each of :data:`TIME_BASES` (``lives_lost_per_step``, ...), for
    a step of ``dt`` seconds."""
    rates = np.asarray(lives_lost_per_s, dtype=np.float64)
    return {f"lives_lost_per_{name}": np.round(rates * steps * dt, 4)
            for name, steps in TIME_BASES.items()}


def _row(strategy: object, configuration: str, runs: list, vehicles: int) -> dict:
    """The runs' rates: lives lost of all vehicles together (``[crowd] counting =
    "lives_lost"``), apart as collisions and spins, and ours per vehicle-second."""
    collisions = np.mean([run.collision_rate for run in runs]) * vehicles
    spins = np.mean([run.spin_rate for run in runs]) * vehicles
    return {"strategy": strategy, "configuration": configuration,
            "collisions_per_s": round(float(collisions), 3),
            "spins_per_s": round(float(spins), 3),
            "lives_lost_per_s": round(float(np.mean([run.rate("lives_lost") for run in runs])), 3),
            "collisions_per_vehicle_s": round(float(np.mean([run.rate("responsible")
                                                             for run in runs])), 4)}


def untrained_run(world: ArenaWorld, situation: int, at_start: bool, learns: bool,
                  key: int = SITUATION_KEY):
    """One span of 8 untrained network drivers in one situation: fixed random networks, or
    learners from random populations of the scenario's size (``learns``)."""
    sc = world.scenario
    chosen = world.situations(key + situation)[0]
    crowd = Crowd(world, chosen.start, np.full(world.vehicles, NETWORK), int(chosen.seed),
                  respawn_at_start=at_start)
    rng = np.random.default_rng([sc.seed, key, situation])
    populations = [world.spec.in_source_layout(ga.initial_population(
        rng, sc.ga.population_size, world.spec.chromosome_length, sc.ga.init_range))
        for _ in range(world.vehicles)]
    learning = None
    if learns:
        learning = OnlineLearning(
            [VehicleGA(p, np.random.default_rng([sc.seed, situation, v]))
             for v, p in enumerate(populations)],
            sc.ga, share_elites=True, elite_count=sc.ga.elite_count)
    return crowd.run(SECONDS, np.stack([p[0] for p in populations]), learning,
                     check_spins=True)


def regime(study: Study) -> list[str]:
    """``regime.csv``: the collision rates of every configuration in the paper's unit."""
    situations = study.settings(LEARNING).situations
    rows = []
    for strategy in ARENA.strategies:
        world = ArenaWorld(shipped_scenario(ARENA.name(strategy)))
        runs = []
        for situation in range(situations):
            crowd, genes = situation_crowd(world, situation)
            runs.append(crowd.run(SECONDS, genes))
        rows.append(_row(strategy, "initial drivers", runs, world.vehicles))
    for configuration, at_start, learns, authors_spin in UNTRAINED:
        scenario = shipped_scenario(ARENA.name(1))
        if authors_spin:
            scenario = scenario.with_overrides(episode=AUTHORS_SPIN)
        world = ArenaWorld(scenario)  # the strategies' arenas differ only in their drivers
        runs = [untrained_run(world, s, at_start, learns) for s in range(situations)]
        rows.append(_row("any", configuration, runs, world.vehicles))
    table = pd.DataFrame(rows)
    dt = shipped_scenario(ARENA.name(1)).vehicle.dt
    for column, rates in time_bases(table["lives_lost_per_s"].to_numpy(), dt).items():
        table[column] = rates
    table["paper_low"], table["paper_high"] = min(PAPER_INITIAL), max(PAPER_INITIAL)
    write_csv(study.out / "regime.csv", table)
    return regime_lines(study)


def regime_lines(study: Study) -> list[str]:
    """The summary's line, from the ``regime.csv`` the study wrote."""
    return [summary_line(pd.read_csv(study.out / "regime.csv"))]


def summary_line(table: pd.DataFrame) -> str:
    """How far each configuration is from the paper's initial rates (its mean)."""
    paper = float(np.mean(PAPER_INITIAL))
    parts = [f"{row.configuration}"
             + (f" (strategy {row.strategy})" if row.strategy != "any" else "")
             + f": {row.collisions_per_s:.2f} collisions + {row.spins_per_s:.2f} spins per s"
             f" (paper / ours: {paper / row.lives_lost_per_s:.0f}x)"
             for row in table.itertuples()]
    return ("regime (all 8 vehicles, the paper's unit; paper's initial rates "
            f"{table['paper_low'].iloc[0]:g}-{table['paper_high'].iloc[0]:g}): "
            + "; ".join(parts))
