"""The world a scenario describes (:class:`enn_traffic.sim.world.World`)."""

from __future__ import annotations

from enn_traffic.roads import Track
from enn_traffic.scenario import Scenario
from enn_traffic.sim.world import World


def make_world(scenario: Scenario, track: Track | None = None) -> World:
    """Arena and navigation worlds, SUMO traffic worlds, or a highway-env lane-keeping road;
    with several tracks, one of these per track side by side
    (:class:`~enn_traffic.sim.tracks.TracksWorld`)."""
    if isinstance(scenario.track, list):
        if len(scenario.track) == 1:
            return make_world(scenario.on_track(0), track)
        from enn_traffic.sim.tracks import TracksWorld

        if track is not None:
            raise ValueError("a track may be given only for a single-track scenario")
        return TracksWorld(scenario, [make_world(scenario.on_track(index))
                                      for index in range(len(scenario.track))])
    if scenario.lane_keeping is not None:
        from enn_traffic.lanekeeping.world import LaneKeepingWorld

        return LaneKeepingWorld(scenario)
    if scenario.traffic.is_sumo:
        from enn_traffic.sim.sumo_world import SumoWorld

        return SumoWorld(scenario, track)
    from enn_traffic.sim.arena import ArenaWorld

    return ArenaWorld(scenario, track)
