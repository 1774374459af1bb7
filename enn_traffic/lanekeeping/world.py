"""Populations of lane-keeping controllers on a highway-env road (paper §5.6).

The same genome and network as everywhere else: inputs are the camera's marking offsets, the
two outputs map to highway-env's steering action as ``left − right`` (in [−1, 1], i.e. up to
±60° of steering). A life ends when the vehicle's centre leaves its lane (highway-env itself
never ends this task); fitness = steps kept in the lane, up to ``episode.max_steps``.
highway-env is plain Python, so a population is evaluated one chromosome after another; use
``--executor process`` to spread it over the cores.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from enn_traffic.lanekeeping.env import lane_markings, lane_offset, make_env, marking_segments
from enn_traffic.network import NetworkSpec, network_buffers
from enn_traffic.network import steering as network_steering
from enn_traffic.scenario import Scenario
from enn_traffic.sim.world import CAPPED, LEFT_LANE, EpisodeResults


@dataclass(frozen=True)
class Road:
    """What drawing needs of the road: its markings (as the arena's walls) and name."""

    walls: np.ndarray
    name: str


class LaneKeepingWorld:
    """A scenario's highway-env road and camera, ready to evaluate populations."""

    vehicles = 1

    def __init__(self, scenario: Scenario):
        self.scenario = scenario
        self.config = scenario.lane_keeping
        self.spec = NetworkSpec(scenario.layer_sizes, scenario.network.layout)
        self.layer_sizes = self.spec.layer_array
        self.env = make_env(self.config)
        self._track: Road | None = None
        self.start = (0.0, 0.0, 0.0)

    @property
    def track(self) -> Road:
        if self._track is None:
            self._track = Road(marking_segments(self.config), f"{self.config.road} road")
        return self._track

    def episode_labels(self) -> list[str]:
        return [f"{self.config.road} road"] * self.config.episodes

    def _rng(self, key: int, episode: int) -> np.random.Generator:
        return np.random.default_rng([self.config.seed, key, episode])

    def episode(self, genes: np.ndarray, rng: np.random.Generator, max_steps: int,
                trace: list | None = None) -> tuple[int, int, float]:
        """One life: (steps kept in the lane, outcome, mean |lateral offset| in metres)."""
        self.env.reset(seed=0)
        vehicle = self.env.unwrapped.vehicle
        activation, scratch = network_buffers(self.layer_sizes)
        action = np.zeros(1)
        offsets = 0.0
        steps = 0
        while True:
            vehicle = self.env.unwrapped.vehicle
            if trace is not None:
                trace.append((*vehicle.position, vehicle.heading))
            offset, half_width = lane_offset(vehicle)
            if abs(offset) > half_width:
                return steps, LEFT_LANE, offsets / max(steps, 1)
            if steps >= max_steps:
                return steps, CAPPED, offsets / max(steps, 1)
            offsets += abs(offset)
            readings = lane_markings(vehicle, self.config.lookahead_m, self.config.noise_m, rng)
            action[0] = network_steering(genes, self.layer_sizes, readings, activation, scratch,
                                         1.0)
            self.env.step(action)
            steps += 1

    def evaluate(self, population: np.ndarray, key: int = 0) -> EpisodeResults:
        """Fitness of every chromosome: steps kept in the lane, averaged over episodes."""
        genes = self.spec.in_source_layout(population)
        episodes = self.config.episodes
        steps = np.zeros((len(genes), episodes), dtype=np.int64)
        outcome = np.zeros((len(genes), episodes), dtype=np.int64)
        for p, row in enumerate(genes):
            for e in range(episodes):
                steps[p, e], outcome[p, e], _ = self.episode(
                    row, self._rng(key, e), self.scenario.episode.max_steps)
        return EpisodeResults.of_lives(steps, outcome)

    def offsets(self, chromosome: np.ndarray, key: int = 0) -> list[tuple[int, int, float]]:
        """Per episode: (steps, outcome, mean |lateral offset|) of one chromosome."""
        genes = self.spec.in_source_layout(chromosome)[0]
        return [self.episode(genes, self._rng(key, e), self.scenario.episode.max_steps)
                for e in range(self.config.episodes)]

    def trace(self, chromosome: np.ndarray, key: int = 0, episode: int = 0,
              max_steps: int | None = None) -> tuple[np.ndarray, int]:
        """The vehicle's poses (n, 1, 3) in one episode and the outcome code."""
        poses: list = []
        limit = self.scenario.episode.max_steps if max_steps is None else max_steps
        genes = self.spec.in_source_layout(chromosome)[0]
        _, outcome, _ = self.episode(genes, self._rng(key, episode), limit, poses)
        return np.array(poses)[:, None, :], int(outcome)
