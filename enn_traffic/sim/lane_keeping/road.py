"""highway-env's lane keeping on roads of our choosing, seen through a lane-detecting camera
(paper §5.6: CarMaker's camera and lane keeping, here with highway-env).

:class:`CameraLaneKeepingEnv` is highway-env's ``lane-keeping-v0`` (a dynamical bicycle model
steered by a continuous action, at 10 Hz) on a sine road of any amplitude and period, or on a
circle, either way round. :func:`lane_markings` is the camera: the lateral offsets, in the
vehicle frame, of the lane's two markings at each look-ahead distance along the lane (positive
to the vehicle's right, highway-env's lateral direction), with optional Gaussian noise. It
reads the vehicle's state after the step, since highway-env's ``step()`` returns an
observation taken before the action is applied.
"""

from __future__ import annotations

import math

import numpy as np
from highway_env.envs.lane_keeping_env import LaneKeepingEnv
from highway_env.road.lane import CircularLane, LineType, SineLane
from highway_env.road.road import Road, RoadNetwork

from enn_traffic.config import LaneKeepingConfig

SPEED = 8.3  # m/s, the speed highway-env's lane-keeping vehicle drives at


class CameraLaneKeepingEnv(LaneKeepingEnv):
    """``lane-keeping-v0`` on the road that ``config["road"]`` describes (a
    :class:`LaneKeepingConfig` as a dict); the vehicle starts on the lane's centre line."""

    def _make_road(self) -> None:
        road = LaneKeepingConfig(**self.config["road"])
        lines = [LineType.CONTINUOUS, LineType.CONTINUOUS]
        network = RoadNetwork()
        side = -1.0 if road.mirrored else 1.0
        if road.road == "sine":
            network.add_lane("a", "b", SineLane(
                [0.0, 0.0], [road.length, 0.0], amplitude=side * road.amplitude,
                pulsation=2 * math.pi / road.period, phase=0.0, width=road.lane_width,
                line_types=lines))  # fmt: skip
        else:  # two half circles from (0, -radius); mirrored, the other way round
            for start, end, phase in (("a", "b", -math.pi / 2), ("b", "a", math.pi / 2)):
                phase = phase if side > 0 else -phase - math.pi  # fmt: skip
                network.add_lane(start, end, CircularLane(
                    [0.0, 0.0], road.radius, phase, phase + side * math.pi,
                    clockwise=not road.mirrored, width=road.lane_width,
                    line_types=lines))  # fmt: skip
        self.lanes, self.lane = [], network.get_lane(("a", "b", 0))
        self.road = Road(network=network, np_random=self.np_random,
                         record_history=self.config["show_trajectories"])

    def _make_vehicles(self) -> None:
        lane = self.road.network.get_lane(("a", "b", 0))
        self.vehicle = self.action_type.vehicle_class(
            self.road, lane.position(0.0, 0.0), heading=lane.heading_at(0.0), speed=SPEED)
        self.road.vehicles.append(self.vehicle)

    def drive(self, action: np.ndarray) -> None:
        """One policy step as ``step()`` drives it (the action, then the simulation), without
        what the camera makes unneeded: ``lane-keeping-v0``'s own observation (noisy state,
        derivative and reference state), reward and trajectory log (1.6-2x the steps per
        second, measured in one process). The vehicle moves exactly as under ``step()``
        (tests/sim/test_lane_keeping.py)."""
        self.action_type.act(action)
        self._simulate()


def make_env(road: LaneKeepingConfig) -> CameraLaneKeepingEnv:
    return CameraLaneKeepingEnv(config={"road": road.model_dump()})


def lane_offset(vehicle) -> tuple[float, float]:
    """The vehicle's lateral offset from its lane's centre line, and the lane's half width."""
    lane = vehicle.lane
    longitudinal, lateral = lane.local_coordinates(vehicle.position)
    return float(lateral), 0.5 * lane.width_at(longitudinal)


def lane_markings(vehicle, lookahead, noise: float, rng: np.random.Generator | None
                  ) -> np.ndarray:
    """The camera: for each look-ahead distance, the lateral offsets (vehicle frame) of the
    markings at −width/2 and +width/2 of the lane, ``2 * len(lookahead)`` values."""
    lane = vehicle.lane
    longitudinal, _ = lane.local_coordinates(vehicle.position)
    cos_h, sin_h = math.cos(vehicle.heading), math.sin(vehicle.heading)
    x, y = vehicle.position
    readings = np.empty(2 * len(lookahead))
    for i, distance in enumerate(lookahead):
        s = longitudinal + distance
        half = 0.5 * lane.width_at(s)
        for j, side in enumerate((-half, half)):
            px, py = lane.position(s, side)
            readings[2 * i + j] = -sin_h * (px - x) + cos_h * (py - y)
    if noise > 0 and rng is not None:
        readings += rng.normal(0.0, noise, readings.shape)
    return readings


def marking_segments(road: LaneKeepingConfig, spacing: float = 2.0) -> np.ndarray:
    """Both markings of the road as segments (x1, y1, x2, y2), for drawing."""
    env = make_env(road)
    env.reset(seed=0)
    segments = []
    for lane in env.unwrapped.road.network.lanes_list():
        s = np.arange(0.0, lane.length + spacing, spacing)
        for side in (-0.5, 0.5):
            points = np.array([lane.position(si, side * lane.width_at(si)) for si in s])
            segments.append(np.hstack([points[:-1], points[1:]]))
    env.close()
    return np.concatenate(segments)
