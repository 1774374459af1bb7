"""The world a scenario describes (:class:`enn_traffic.sim.world.World`)."""

from __future__ import annotations

from enn_traffic.roads import Track
from enn_traffic.scenario import Scenario
from enn_traffic.sim.world import World


def make_world(scenario: Scenario, track: Track | None = None) -> World:
    """Arena and navigation worlds, SUMO traffic worlds, or a highway-env lane-keeping road."""
    if scenario.lane_keeping is not None:
        from enn_traffic.lanekeeping.world import LaneKeepingWorld

        return LaneKeepingWorld(scenario)
    if scenario.traffic.is_sumo:
        from enn_traffic.sim.sumo_world import SumoWorld

        return SumoWorld(scenario, track)
    from enn_traffic.sim.arena import ArenaWorld

    return ArenaWorld(scenario, track)
