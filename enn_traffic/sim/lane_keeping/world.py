"""Populations of lane-keeping controllers on a highway-env road (paper §5.6).

The same genome and network as everywhere else: inputs are the camera's marking offsets, the
two outputs map to highway-env's steering action as ``left − right`` (in [−1, 1], i.e. up to
±60° of steering). A life ends when the vehicle's centre leaves its lane (highway-env itself
never ends this task); fitness = steps kept in the lane, up to ``episode.max_steps``, averaged
over the situations, each on the scenario's road or on one drawn for it
(``[lane_keeping.draw]``).
highway-env is plain Python, so a population is evaluated one chromosome after another; use
``--executor process`` to spread it over the cores.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from enn_traffic.config import LaneKeepingConfig, Scenario
from enn_traffic.core.neural import NetworkSpec, network_buffers
from enn_traffic.core.neural import steering as network_steering
from enn_traffic.sim.lane_keeping.road import lane_markings, lane_offset, make_env, marking_segments
from enn_traffic.sim.world import CAPPED, LEFT_LANE, SituationResults

ROAD_STREAM = 1  # the drawn roads' own stream, apart from the camera noise's
KEPT_ENVS = 16


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
        self._envs: dict[tuple, object] = {}
        self._track: Road | None = None

    @property
    def track(self) -> Road:
        if self._track is None:
            self._track = Road(marking_segments(self.config), f"{self.config.road} road")
        return self._track

    def situation_labels(self) -> list[str]:
        road = "drawn" if self.config.draw is not None else self.config.road
        return [f"{road} road"] * self.config.episodes

    def _rng(self, key: int, situation: int) -> np.random.Generator:
        return np.random.default_rng([self.config.seed, key, situation])

    def road_of(self, key: int, situation: int) -> LaneKeepingConfig:
        """The road of situation (``key``, ``situation``): the scenario's, or with
        ``[lane_keeping.draw]`` one drawn from (seed, key, situation) alone."""
        draw = self.config.draw
        if draw is None:
            return self.config
        rng = np.random.default_rng([self.config.seed, key, situation, ROAD_STREAM])
        values = {"road": draw.roads[rng.integers(len(draw.roads))],
                  "amplitude": rng.uniform(*draw.amplitude), "period": rng.uniform(*draw.period),
                  "radius": rng.uniform(*draw.radius)}
        values["mirrored"] = bool(rng.integers(2)) and draw.both_directions
        return self.config.model_copy(update=values)

    def _env(self, road: LaneKeepingConfig):
        """highway-env on ``road``, made once (the last ``KEPT_ENVS`` roads are kept)."""
        shape = (road.road, road.amplitude, road.period, road.radius, road.mirrored)
        if shape not in self._envs:
            if len(self._envs) >= KEPT_ENVS:
                self._envs.pop(next(iter(self._envs))).close()
            self._envs[shape] = make_env(road)
        return self._envs[shape]

    def life(self, genes: np.ndarray, rng: np.random.Generator, max_steps: int,
                trace: list | None = None, road: LaneKeepingConfig | None = None
                ) -> tuple[int, int, float]:
        """One life on ``road`` (the scenario's by default): (steps kept in the lane, outcome,
        mean |lateral offset| in metres)."""
        env = self._env(self.config if road is None else road)
        env.reset(seed=0)
        vehicle = env.unwrapped.vehicle
        activation, scratch = network_buffers(self.layer_sizes)
        action = np.zeros(1)
        offsets = 0.0
        steps = 0
        while True:
            vehicle = env.unwrapped.vehicle
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
            env.unwrapped.drive(action)
            steps += 1

    def evaluate(self, population: np.ndarray, key: int = 0) -> SituationResults:
        """Fitness of every chromosome: steps kept in the lane, averaged over situations."""
        genes = self.spec.in_source_layout(population)
        episodes = self.config.episodes
        steps = np.zeros((len(genes), episodes), dtype=np.int64)
        outcome = np.zeros((len(genes), episodes), dtype=np.int64)
        roads = [self.road_of(key, e) for e in range(episodes)]
        for p, row in enumerate(genes):
            for e, road in enumerate(roads):
                steps[p, e], outcome[p, e], _ = self.life(
                    row, self._rng(key, e), self.scenario.episode.max_steps, road=road)
        return SituationResults.of_lives(steps, outcome)

    def offsets(self, chromosome: np.ndarray, key: int = 0) -> list[tuple[int, int, float]]:
        """Per situation: (steps, outcome, mean |lateral offset|) of one chromosome."""
        genes = self.spec.in_source_layout(chromosome)[0]
        return [self.life(genes, self._rng(key, e), self.scenario.episode.max_steps,
                             road=self.road_of(key, e))
                for e in range(self.config.episodes)]

    def trace(self, chromosome: np.ndarray, key: int = 0, situation: int = 0,
              max_steps: int | None = None) -> tuple[np.ndarray, int]:
        """The vehicle's poses (n, 1, 3) in one life and the outcome code."""
        poses: list = []
        limit = self.scenario.episode.max_steps if max_steps is None else max_steps
        genes = self.spec.in_source_layout(chromosome)[0]
        _, outcome, _ = self.life(genes, self._rng(key, situation), limit, poses,
                                     road=self.road_of(key, situation))
        return np.array(poses)[:, None, :], int(outcome)
