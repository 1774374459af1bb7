"""The world a scenario describes (:class:`enn_traffic.sim.world.World`), by its kind
(:attr:`enn_traffic.scenario.Scenario.world_kind`)."""

from __future__ import annotations

from enn_traffic.kinds import Registry
from enn_traffic.roads import Track
from enn_traffic.scenario import Scenario, network_named
from enn_traffic.sim.world import World

# Each world kind's class, imported when first made (an arena run does not load SUMO). A
# world is made as ``World(scenario, track)``; several tracks as ``World(scenario, worlds)``.
WORLDS = Registry("world kind", {
    "arena": "enn_traffic.sim.arena:ArenaWorld",
    "sumo": "enn_traffic.sim.sumo_world:SumoWorld",
    "lane_keeping": "enn_traffic.lanekeeping.world:LaneKeepingWorld",
    "tracks": "enn_traffic.sim.tracks:TracksWorld",
})


def make_world(scenario: Scenario, track: Track | None = None) -> World:
    """Arena and navigation worlds, SUMO traffic worlds, or a highway-env lane-keeping road;
    with several tracks, one of these per track side by side
    (:class:`~enn_traffic.sim.tracks.TracksWorld`). ``track``: the road already read, for a
    scenario of one track."""
    if isinstance(scenario.track, list) and len(scenario.track) == 1:
        scenario = scenario.on_track(0)
    kind = scenario.world_kind
    if kind == "tracks":
        if track is not None:
            raise ValueError("a track may be given only for a single-track scenario")
        return WORLDS[kind](scenario, [make_world(scenario.on_track(index))
                                       for index in range(len(scenario.track))])
    with network_named(scenario):
        return WORLDS[kind](scenario, track)
