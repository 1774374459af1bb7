"""Several tracks at once: a scenario with ``[[track]]`` entries trains one controller on all
of them (docs/scenarios.md, "Several tracks").

The paper trains on one track and reports that the controllers "navigate other tracks" (§5.1);
training across tracks makes that a goal of the fitness rather than a hope. Each track is a
world of its own kind (arena or SUMO traffic), built from the scenario on that track alone; a
chromosome drives every situation of every track, and its fitness is the mean over all of them,
as it is over traffic strategies (§5.4.1).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from enn_traffic.config import Scenario
from enn_traffic.sim.world import SituationResults, World


class TracksWorld:
    """The worlds of a scenario's tracks, evaluated side by side: the per-situation arrays of
    :meth:`evaluate` hold the first track's situations, then the second's, and so on."""

    def __init__(self, scenario: Scenario, worlds: list[World]):
        self.scenario = scenario
        self.worlds = worlds
        self.spec = worlds[0].spec
        self.vehicles = max(world.vehicles for world in worlds)
        self.track = worlds[0].track  # the first situation's, for drawing it
        self._situations = [len(world.situation_labels()) for world in worlds]

    def evaluate(self, population: np.ndarray, key: int = 0) -> SituationResults:
        """Fitness of every chromosome: the mean over every track's situations of ``key``."""
        parts = [world.evaluate(population, key) for world in self.worlds]
        return replace(SituationResults.concatenate(parts, axis=1), vehicles=self.vehicles)

    def situation_labels(self) -> list[str]:
        """``track: strategy`` of each column of :meth:`evaluate`'s per-situation arrays."""
        return [f"{world.track.name}: {label}" for world in self.worlds
                for label in world.situation_labels()]

    def world_of(self, situation: int) -> tuple[World, int]:
        """The world that situation ``situation`` (a column of :meth:`evaluate`) is on, and its
        number there."""
        for world, count in zip(self.worlds, self._situations, strict=True):
            if situation < count:
                return world, situation
            situation -= count
        raise IndexError(f"situation {situation} is beyond the scenario's "
                         f"{sum(self._situations)}")

    def trace(self, chromosome: np.ndarray, key: int = 0, situation: int = 0,
              max_steps: int | None = None) -> tuple[np.ndarray, int]:
        """Poses (n, V, 3) of one situation, and the learner's outcome code."""
        world, situation = self.world_of(situation)
        return world.trace(chromosome, key, situation, max_steps)
