"""The columns of a run's ``generations.csv``, one registered function each, in the order
they are written: a new column is one function here (docs/design.md, "Architecture").

Each function takes the :class:`Generation` just evaluated and returns the column's value.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from enn_traffic.scenario import Scenario
from enn_traffic.sim.sumo_situations import warmups_used
from enn_traffic.sim.world import CAPPED, COLLIDED, LEFT_LANE, LEFT_NETWORK, SPUN, SituationResults


@dataclass(frozen=True)
class Generation:
    """One evaluated generation of a run: its scenario, its number, the results of its
    chromosomes, and the run's compute time up to its end."""

    scenario: Scenario
    number: int
    results: SituationResults
    elapsed_s: float

    @property
    def fitness(self) -> np.ndarray:
        return self.results.fitness


COLUMNS: dict[str, Callable[[Generation], object]] = {}


def column(function: Callable[[Generation], object]) -> Callable[[Generation], object]:
    """Register ``function`` as the column of its name, after those registered before."""
    COLUMNS[function.__name__] = function
    return function


def row(evaluated: Generation) -> dict[str, object]:
    """The generation's row of ``generations.csv``."""
    return {name: value(evaluated) for name, value in COLUMNS.items()}


def _ended(evaluated: Generation, outcome: int) -> int:
    return int((evaluated.results.outcome == outcome).sum())


@column
def generation(evaluated: Generation) -> int:
    return evaluated.number


@column
def best_fitness(evaluated: Generation) -> float:
    return evaluated.fitness.max()


@column
def mean_fitness(evaluated: Generation) -> float:
    return evaluated.fitness.mean()


@column
def median_fitness(evaluated: Generation) -> float:
    return float(np.median(evaluated.fitness))


@column
def min_fitness(evaluated: Generation) -> float:
    return evaluated.fitness.min()


@column
def vehicle_steps(evaluated: Generation) -> int:
    """Steps moved by every simulated vehicle."""
    return evaluated.results.vehicle_steps


@column
def collisions(evaluated: Generation) -> int:
    """Lives that ended in a collision the learner caused (paper §5.3's blame rule)."""
    return _ended(evaluated, COLLIDED)


@column
def vehicle_collisions(evaluated: Generation) -> int:
    """Of those, the ones with a vehicle (the rest: walls)."""
    return evaluated.results.vehicle_collisions


@column
def spins(evaluated: Generation) -> int:
    return _ended(evaluated, SPUN)


@column
def capped(evaluated: Generation) -> int:
    return _ended(evaluated, CAPPED)


@column
def left_network(evaluated: Generation) -> int:
    return _ended(evaluated, LEFT_NETWORK)


@column
def left_lane(evaluated: Generation) -> int:
    return _ended(evaluated, LEFT_LANE)


@column
def suffered(evaluated: Generation) -> int:
    """Collisions other vehicles caused the learners."""
    return int(evaluated.results.suffered.sum())


@column
def traffic_at_start(evaluated: Generation) -> float:
    """Vehicles in the world when the learner starts (docs/sumo.md, "No silent empty
    traffic"), and below, within sensor range per learner step and at most."""
    return evaluated.results.traffic_summary()["traffic_at_start"]


@column
def traffic_near_mean(evaluated: Generation) -> float:
    return evaluated.results.traffic_summary()["traffic_near_mean"]


@column
def traffic_near_max(evaluated: Generation) -> float:
    return evaluated.results.traffic_summary()["traffic_near_max"]


@column
def warmups(evaluated: Generation) -> str:
    """Which SUMO warm-ups the generation's situations loaded."""
    return warmups_used(evaluated.scenario, evaluated.number)


@column
def elapsed_s(evaluated: Generation) -> float:
    return evaluated.elapsed_s
