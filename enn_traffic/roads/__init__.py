"""SUMO's files read without SUMO (sumolib, shapely): a network as walls and start poses, a
``.sumocfg``, and the lanes a learner may start on; every XML reader feeds expat 16 MB blocks
(``xmlread``: expat before 2.6 is quadratic in a token cut by a block's end)."""

from enn_traffic.roads.network import Track, load_track

__all__ = ["Track", "load_track"]
