"""SUMO road networks as walls and start poses (sumolib + shapely)."""

from enn_traffic.roads.network import Track, load_track

__all__ = ["Track", "load_track"]
