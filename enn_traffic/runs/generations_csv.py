"""The columns of a run's ``generations.csv``, one registered function each, in the order
they are written: a new column is one function here (docs/design.md, "Architecture").

Each function takes the :class:`Generation` just evaluated and returns the column's value.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from enn_traffic.config import Scenario
from enn_traffic.sim.sumo.situations import warmups_used
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
    """The generation's number, from 0."""
    return evaluated.number


@column
def best_fitness(evaluated: Generation) -> float:
    """The best chromosome's fitness: steps survived, averaged over the generation's
    situations (0 for a spin, paper §5.3)."""
    return evaluated.fitness.max()


@column
def mean_fitness(evaluated: Generation) -> float:
    """The population's mean fitness."""
    return evaluated.fitness.mean()


@column
def median_fitness(evaluated: Generation) -> float:
    """The population's median fitness."""
    return float(np.median(evaluated.fitness))


@column
def min_fitness(evaluated: Generation) -> float:
    """The worst chromosome's fitness."""
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
    """Lives that ended spinning in place (paper §5.3's rule: fitness 0)."""
    return _ended(evaluated, SPUN)


@column
def capped(evaluated: Generation) -> int:
    """Lives still going at the step cap (`episode.max_steps`) or at the end of SUMO's
    simulation."""
    return _ended(evaluated, CAPPED)


@column
def left_network(evaluated: Generation) -> int:
    """Lives that ended at an exit: the learner's body touched the network's fringe, where
    roads leave a SUMO map (docs/sumo.md, "Walls and exits")."""
    return _ended(evaluated, LEFT_NETWORK)


@column
def left_lane(evaluated: Generation) -> int:
    """Lane keeping only (paper §5.6): lives that ended with the vehicle across a lane
    marking."""
    return _ended(evaluated, LEFT_LANE)


@column
def suffered(evaluated: Generation) -> int:
    """Collisions other vehicles caused the learners."""
    return int(evaluated.results.suffered.sum())


@column
def traffic_at_start(evaluated: Generation) -> float:
    """Vehicles in the world when the learner starts, mean over its worlds and situations
    (docs/sumo.md, "No silent empty traffic")."""
    return evaluated.results.traffic_summary()["traffic_at_start"]


@column
def traffic_near_mean(evaluated: Generation) -> float:
    """Vehicles within sensor range per learner step, mean."""
    return evaluated.results.traffic_summary()["traffic_near_mean"]


@column
def traffic_near_max(evaluated: Generation) -> float:
    """The most vehicles within sensor range at once."""
    return evaluated.results.traffic_summary()["traffic_near_max"]


@column
def warmups(evaluated: Generation) -> str:
    """Which SUMO warm-ups the generation's situations loaded."""
    return warmups_used(evaluated.scenario, evaluated.number)


@column
def elapsed_s(evaluated: Generation) -> float:
    """The run's compute time up to the end of this generation (s)."""
    return evaluated.elapsed_s
