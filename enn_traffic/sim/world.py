"""What every kind of world is to the rest of the project: the :class:`World` protocol, the
outcomes of a life and the :class:`SituationResults` a world's evaluation gives (paper §5, §5.3).

Worlds: :class:`~enn_traffic.sim.arena.ArenaWorld` (the arena and the navigation tracks, with
scripted or network traffic), :class:`~enn_traffic.sim.sumo.world.SumoWorld` (SUMO's traffic,
replay or closed loop) and :class:`~enn_traffic.sim.lane_keeping.world.LaneKeepingWorld`
(highway-env). :func:`enn_traffic.sim.world.make_world` gives the one a scenario describes.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol, runtime_checkable

import numpy as np

from enn_traffic.config import Scenario, network_named
from enn_traffic.core.neural import NetworkSpec
from enn_traffic.core.registry import Registry

# How a life ended. LEFT_NETWORK: the learner reached the network's fringe (SUMO traffic,
# docs/sumo.md "Walls and exits"); LEFT_LANE: the lane-keeping vehicle crossed a marking. A
# life that left the network or was capped counts its steps as fitness, as does a lane
# departure (paper §5.6: the steps kept in the lane).
CAPPED, COLLIDED, SPUN, LEFT_NETWORK, LEFT_LANE = 0, 1, 2, 3, 4
RUNNING = -1  # a step's outcome while the life goes on
# What a collision was with (``SituationResults.hit``), besides a vehicle (0, 1, ...).
NO_HIT, HIT_WALL = -1, -2
OUTCOMES = {CAPPED: "capped", COLLIDED: "collision", SPUN: "spin", LEFT_NETWORK: "left network",
            LEFT_LANE: "left lane"}
# Columns of :attr:`SituationResults.traffic`: vehicles in the world when the learner starts,
# vehicle-steps within the learner's sensor range, most vehicles within range at once.
MET_START, MET_NEAR_STEPS, MET_NEAR_MAX = range(3)


class Drawn(Protocol):
    """What a world shows of where it drives: a name and wall segments (S, 4), x1 y1 x2 y2
    (a track's walls, a road's lane markings)."""

    name: str
    walls: np.ndarray


@runtime_checkable
class World(Protocol):
    """A scenario's worlds, ready to evaluate populations of controllers.

    ``key`` is a traffic key (:mod:`enn_traffic.core.keys`): a training generation's number, or a
    held-out key; the same key gives every chromosome the same traffic situations."""

    scenario: Scenario
    spec: NetworkSpec
    vehicles: int  # vehicles simulated per world
    track: Drawn  # the track or road (the first, of several) that tables name and plots draw

    def evaluate(self, population: np.ndarray, key: int = 0) -> SituationResults:
        """Fitness and per-situation results of every chromosome (P, G)."""
        ...

    def situation_labels(self) -> list[str]:
        """What each column of the per-situation arrays is (a strategy, a road)."""
        ...

    def trace(self, chromosome: np.ndarray, key: int = 0, situation: int = 0,
              max_steps: int | None = None) -> tuple[np.ndarray, int]:
        """Poses (n, V, 3) of one situation, and the learner's outcome code."""
        ...


@dataclass(frozen=True)
class SituationResults:
    """Per world and situation (P, E): learner steps, outcome (``OUTCOMES``), collisions the
    learner suffered, the traffic it met (P, E, 3; columns ``MET_*``) and what it ran into
    (``hit``: ``NO_HIT``, ``HIT_WALL``, or the vehicle: an arena vehicle's index, a SUMO
    vehicle's number in its situation; ``hit_vehicle``: that SUMO vehicle's id and type, where
    known; ``end_pose``: the learner's pose as its life ended, where known); fitness (P,) is
    the mean over situations of steps, 0 for a spin."""

    fitness: np.ndarray
    steps: np.ndarray
    outcome: np.ndarray
    suffered: np.ndarray
    vehicles: int = 1
    traffic: np.ndarray | None = None
    # (P, E, 6), closed loop with SUMO only: the lowest time-to-collision its SSM device saw
    # (s; inf: none), then conflicts by TTC, DRAC and PET; the least two-dimensional time to
    # collision over the footprints (enn_traffic.sim.safety) and the steps it was below 1.5 s
    safety: np.ndarray | None = None
    hit: np.ndarray | None = None
    hit_vehicle: np.ndarray | None = None  # (P, E) objects: (id, type), or None
    end_pose: np.ndarray | None = None  # (P, E, 3): x, y (m, the network's), heading (rad)

    def __post_init__(self):
        if self.traffic is None:  # no traffic: nothing met
            object.__setattr__(self, "traffic", np.zeros((*self.steps.shape, 3)))
        if self.hit is None:  # nothing known: walls for the collisions
            object.__setattr__(self, "hit", np.where(self.outcome == COLLIDED, HIT_WALL, NO_HIT))

    @classmethod
    def of_lives(cls, steps: np.ndarray, outcome: np.ndarray, suffered: np.ndarray | None = None,
                 vehicles: int = 1, traffic: np.ndarray | None = None,
                 safety: np.ndarray | None = None, hit: np.ndarray | None = None,
                 hit_vehicle: np.ndarray | None = None,
                 end_pose: np.ndarray | None = None) -> SituationResults:
        """From every life (P, E): fitness is the mean over the situations of
        :meth:`lifetime_fitness`."""
        fitness = cls.lifetime_fitness(steps, outcome).mean(axis=1)
        suffered = np.zeros_like(steps) if suffered is None else suffered
        return cls(fitness, steps, outcome, suffered, vehicles, traffic, safety, hit,
                   hit_vehicle, end_pose)

    @classmethod
    def of_situations(cls, runs: list[tuple], vehicles: int, at_start: list,
                      safety: np.ndarray | None = None,
                      hit_vehicle: np.ndarray | None = None,
                      end_pose: np.ndarray | None = None) -> SituationResults:
        """From a compiled batch's (steps, outcome, suffered, vehicle-steps within range, most
        within range, what was hit), each (P,), per situation; ``at_start``: the vehicles in
        the world at the learner's start, per situation (a number, or one per world)."""
        steps, outcome, suffered, near_steps, near_max, hit = (
            np.stack([r[i] for r in runs], axis=1) for i in range(6))
        start = np.column_stack([np.broadcast_to(a, len(steps)) for a in at_start])
        return cls.of_lives(steps, outcome, suffered, vehicles,
                            cls.traffic_met(start, near_steps, near_max), safety, hit,
                            hit_vehicle, end_pose)

    @staticmethod
    def traffic_met(start: np.ndarray, near_steps: np.ndarray, near_max: np.ndarray
                    ) -> np.ndarray:
        """The ``traffic`` array from its three (P, E) columns."""
        return np.stack(np.broadcast_arrays(start, near_steps, near_max), axis=-1
                        ).astype(np.float64)

    def traffic_summary(self) -> dict[str, float]:
        """Traffic the learners met, over all worlds and situations: vehicles in the world at
        the start (mean), vehicles within sensor range per learner step (mean; the steps of
        the life and the start) and at most."""
        t = self.traffic
        return {
            "traffic_at_start": float(t[..., MET_START].mean()) if t.size else 0.0,
            "traffic_near_mean": float(t[..., MET_NEAR_STEPS].sum() / (self.steps + 1).sum())
            if t.size else 0.0,
            "traffic_near_max": float(t[..., MET_NEAR_MAX].max()) if t.size else 0.0,
        }

    @staticmethod
    def lifetime_fitness(steps: np.ndarray, outcome: np.ndarray) -> np.ndarray:
        """Fitness of each life (paper §5, §5.3): steps survived, 0 for a spin."""
        return np.where(outcome == SPUN, 0, steps).astype(np.float64)

    @property
    def vehicle_collisions(self) -> int:
        """Lives that ended by running into a vehicle (the rest of the collisions: walls)."""
        return int(((self.outcome == COLLIDED) & (self.hit >= 0)).sum())

    @property
    def vehicle_steps(self) -> int:
        """Steps moved by every simulated vehicle."""
        return int(self.steps.sum()) * self.vehicles

    @staticmethod
    def concatenate(parts: list[SituationResults], axis: int = 0) -> SituationResults:
        """Results of several batches of worlds (``axis = 0``), or of several sets of
        situations of the same worlds (``axis = 1``)."""
        def joined(name: str) -> np.ndarray | None:
            arrays = [getattr(p, name) for p in parts]
            return None if any(a is None for a in arrays) else np.concatenate(arrays, axis)

        steps, outcome = joined("steps"), joined("outcome")
        return SituationResults.of_lives(
            steps, outcome, joined("suffered"), vehicles=parts[0].vehicles,
            traffic=joined("traffic"), safety=joined("safety"), hit=joined("hit"),
            hit_vehicle=joined("hit_vehicle"), end_pose=joined("end_pose"))


# Each world kind's class, imported when first made (an arena run does not load SUMO). A
# world is made as ``World(scenario)``; several tracks as ``World(scenario, worlds)``.
WORLDS = Registry("world kind", {
    "arena": "enn_traffic.sim.arena:ArenaWorld",
    "sumo": "enn_traffic.sim.sumo.world:SumoWorld",
    "lane_keeping": "enn_traffic.sim.lane_keeping.world:LaneKeepingWorld",
    "tracks": "enn_traffic.sim.tracks:TracksWorld",
})


def make_world(scenario: Scenario) -> World:
    """Arena and navigation worlds, SUMO traffic worlds, or a highway-env lane-keeping road;
    with several tracks, one of these per track side by side
    (:class:`~enn_traffic.sim.tracks.TracksWorld`)."""
    if isinstance(scenario.track, list) and len(scenario.track) == 1:
        scenario = scenario.on_track(0)
    kind = scenario.world_kind
    if kind == "tracks":
        return WORLDS[kind](scenario, [make_world(scenario.on_track(index))
                                       for index in range(len(scenario.track))])
    with network_named(scenario):
        return WORLDS[kind](scenario)
