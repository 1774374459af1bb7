"""SUMO's files read without SUMO (sumolib, shapely): a network as walls and start poses, a
``.sumocfg``, and the lanes a learner may start on."""

from enn_traffic.roads.network import Track, load_track

__all__ = ["Track", "load_track"]
