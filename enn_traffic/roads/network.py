"""A SUMO ``.net.xml`` becomes walls: the boundary of the union of lane and junction shapes.

DESIGN.md, "SUMO": the drivable area is the union of lane shapes (each lane's centre line
buffered by half its width, flat ends) and junction polygons; every edge of its boundary,
exterior and holes alike, is one wall segment.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ElementTree
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import sumolib
from shapely.geometry import LineString, MultiPolygon, Point, Polygon
from shapely.ops import unary_union

from enn_traffic.errors import InputError


@dataclass(frozen=True)
class Track:
    """Walls of a road network and its drivable area."""

    name: str
    walls: np.ndarray  # (S, 4) float64: x1, y1, x2, y2 in metres
    area: Polygon | MultiPolygon

    @property
    def bounds(self) -> tuple[float, float, float, float]:
        return self.area.bounds

    def contains(self, x: float, y: float) -> bool:
        return bool(self.area.buffer(1e-9).contains(Point(x, y)))

    def lane_pose(self, net_file: Path, lane_id: str, offset: float) -> tuple[float, float, float]:
        """(x, y, heading) at ``offset`` metres along the centre line of ``lane_id``."""
        net = _read_net(net_file)
        try:
            lane = net.getLane(lane_id)
        except KeyError:
            raise InputError(f"no lane {lane_id!r} in the network", net_file) from None
        shape = LineString(lane.getShape())
        offset = min(max(offset, 0.0), shape.length)
        point = shape.interpolate(offset)
        ahead = shape.interpolate(min(offset + 0.1, shape.length))
        behind = shape.interpolate(max(offset - 0.1, 0.0))
        heading = math.atan2(ahead.y - behind.y, ahead.x - behind.x)
        return point.x, point.y, heading


def _read_net(path: Path) -> sumolib.net.Net:
    if not path.is_file():
        raise InputError("network file not found", path)
    try:
        return sumolib.net.readNet(str(path), withInternal=True)
    except ElementTree.ParseError as exc:
        raise InputError(f"not a readable SUMO network: {exc}", path) from None
    except Exception as exc:  # sumolib raises plain exceptions on malformed nets
        message = f"not a readable SUMO network: {type(exc).__name__}: {exc}"
        raise InputError(message, path) from None


def drivable_area(net: sumolib.net.Net) -> Polygon | MultiPolygon:
    """Union of every lane and junction shape of ``net``."""
    pieces = []
    for edge in net.getEdges(withInternal=True):
        for lane in edge.getLanes():
            shape = lane.getShape()
            if len(shape) >= 2:
                pieces.append(
                    LineString(shape).buffer(
                        lane.getWidth() / 2, cap_style="flat", join_style="mitre"
                    )
                )
    for node in net.getNodes():
        shape = node.getShape()
        if len(shape) >= 3:
            polygon = Polygon(shape)
            pieces.append(polygon if polygon.is_valid else polygon.buffer(0))
    # Snap away slivers between abutting shapes, then drop collinear vertices.
    return unary_union(pieces).buffer(1e-6, join_style="mitre").buffer(
        -1e-6, join_style="mitre"
    ).simplify(1e-3)


def boundary_segments(area: Polygon | MultiPolygon) -> np.ndarray:
    """Every edge of the boundary of ``area`` as rows ``x1, y1, x2, y2``."""
    polygons = list(area.geoms) if isinstance(area, MultiPolygon) else [area]
    rows = []
    for polygon in polygons:
        for ring in (polygon.exterior, *polygon.interiors):
            xy = np.asarray(ring.coords)
            rows.append(np.hstack([xy[:-1], xy[1:]]))
    return np.vstack(rows) if rows else np.empty((0, 4))


def load_track(net_file: str | Path) -> Track:
    """Read a SUMO network and return its walls; a clear :class:`InputError` if it has none."""
    path = Path(net_file)
    net = _read_net(path)
    area = drivable_area(net)
    if area.is_empty or area.area <= 0:
        raise InputError("the network has no drivable area (no lanes or junctions)", path)
    return Track(name=path.name.removesuffix(".net.xml"), walls=boundary_segments(area), area=area)
