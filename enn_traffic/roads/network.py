"""A SUMO ``.net.xml`` becomes walls: the boundary of the union of lane and junction shapes.

docs/sumo.md, "Walls and exits": the drivable area is the union of lane shapes (each lane's
centre line buffered by half its width, flat ends) and junction polygons; every edge of its
boundary, exterior and holes alike, is one wall segment. Holes narrower than ``SLIVER_M``
(the millimetre gaps between abutting lanes of imported networks) are road, not walls. With
``exits``, the network's fringe (a node with a single neighbour: where traffic enters or
leaves the map) is cut open across the road, and the cut lines become exits, not walls.

The surface is the learner's (``surface = "passenger"``, docs/sumo.md "Road surface"): the
lanes that allow passenger cars, and the junctions they meet less their walking areas, so that
sidewalks, bike lanes, tram tracks and railways are not road; ``"all"`` takes every lane and
junction. A network's walls are built once and kept on disk (:mod:`enn_traffic.core.cache`).
"""

from __future__ import annotations

import functools
import math
import xml.etree.ElementTree as ElementTree
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Literal

import numpy as np
import shapely
import sumolib
from shapely.geometry import LineString, MultiPolygon, Point, Polygon
from shapely.ops import unary_union

from enn_traffic.core import cache
from enn_traffic.core.cache import file_stamp
from enn_traffic.core.errors import InputError
from enn_traffic.core.geometry import body_corners
from enn_traffic.core.io import check_input_file
from enn_traffic.core.progress import slow_step
from enn_traffic.roads.sumocfg import xml_problem
from enn_traffic.roads.xmlread import read_sumo_net

SLIVER_M = 0.2  # holes narrower than this are gaps between lanes, not walls
SNAP_M = 0.05  # gaps between lane and junction shapes up to twice this are closed
EXIT_MARGIN_M = 0.5  # a fringe cut reaches this far past the road's outer lane edges
# ``start_anywhere``: candidate starts this far apart along each lane, the body this far from
# the walls, and this much room straight ahead (ten steps at 10 m/s: time to see and turn).
ANYWHERE_SPACING_M = 5.0
ANYWHERE_CLEARANCE_M = 1.0
ANYWHERE_AHEAD_M = 10.0
NEAREST_LANE_M = 10.0  # a point farther than this from every lane's centre line is on none


def least_start_length(offset: float, body: float) -> float:
    """The shortest lane a learner may start on (``start_lane = "auto"``, and what
    ``enn-traffic lanes`` lists): room for its ``start_offset``, its ``body`` and
    :data:`ANYWHERE_AHEAD_M` of road ahead."""
    return offset + body + ANYWHERE_AHEAD_M


REMNANT_M = 0.25  # junction remnants thinner than twice this, once walking areas are cut out
LEARNER_CLASS = "passenger"  # the SUMO vehicle class the learner drives as
Surface = Literal["passenger", "all"]
# Raised when the walls a network gives change (so that cached walls are built again).
WALLS_VERSION = 1


@dataclass(frozen=True)
class Track:
    """Walls of a road network, its drivable area, and its exits (segments across the road
    at the fringe; none unless asked for)."""

    name: str
    walls: np.ndarray  # (S, 4) float64: x1, y1, x2, y2 in metres
    area: Polygon | MultiPolygon
    exits: np.ndarray = field(default_factory=lambda: np.empty((0, 4)))

    @property
    def bounds(self) -> tuple[float, float, float, float]:
        return self.area.bounds

    def contains(self, x: float, y: float) -> bool:
        return bool(self.area.buffer(1e-9).contains(Point(x, y)))

    def coverage(self, xy: np.ndarray, cell: float = 5.0) -> float:
        """Share of the drivable area that the path ``xy`` (n, 2) passed over: of the
        ``cell``-metre squares whose centre is on the area, those the path entered. A path
        that reaches the step cap by circling in one place covers little of the track."""
        x0, y0, x1, y1 = self.bounds
        columns, rows = int((x1 - x0) // cell) + 1, int((y1 - y0) // cell) + 1
        cx, cy = np.meshgrid(x0 + (np.arange(columns) + 0.5) * cell,
                             y0 + (np.arange(rows) + 0.5) * cell)
        on_area = shapely.contains_xy(self.area, cx, cy)
        index = np.floor((np.asarray(xy)[:, :2] - (x0, y0)) / cell).astype(np.int64)
        inside = ((index >= 0) & (index < (columns, rows))).all(axis=1)
        visited = np.zeros_like(on_area)
        visited[index[inside, 1], index[inside, 0]] = True
        return float((visited & on_area).sum() / max(on_area.sum(), 1))

    def lane_pose(self, net_file: Path, lane_id: str, offset: float) -> tuple[float, float, float]:
        """(x, y, heading) at ``offset`` metres along the centre line of ``lane_id``."""
        return lane_start_poses(net_file, [("lane", lane_id)], offset)[0]


def body_on_road(area: Polygon | MultiPolygon, pose: tuple[float, float, float],
                 length: float, width: float) -> bool:
    """Does a ``length`` x ``width`` body whose front bumper's middle is at ``pose`` (x, y,
    heading) lie inside the road surface ``area``, touching none of its walls?"""
    corners = np.empty((4, 2))
    body_corners(*pose, length, width, corners)
    return bool(area.contains_properly(Polygon(corners)))


def clear_starts(net_file: Path, offset: float, length: float, width: float,
                 surface: Surface = "passenger", exits: bool = True) -> Callable[[str], bool]:
    """A test of a lane as a start: does a ``length`` x ``width`` body ``offset`` metres along
    it lie on the road ``surface`` (:func:`body_on_road`)? A lane passes every other check and
    still fails this one where it bends or narrows there."""
    area = load_track(net_file, exits=exits, surface=surface).area

    def clear(lane: str) -> bool:
        pose = lane_start_poses(net_file, [("lane", lane)], offset)[0]
        return body_on_road(area, pose, length, width)

    return clear


def lane_start_poses(net_file: Path, names: list[tuple[str, str]], offset: float
                ) -> list[tuple[float, float, float]]:
    """(x, y, heading) at ``offset`` metres along each start's centre line: a lane
    ``("lane", id)``, or an edge ``("edge", id)``, whose rightmost lane that allows passenger
    cars is taken. A ValueError ``(index, message)`` for a start that does not exist, does
    not allow passenger cars, or is shorter than ``offset``."""
    net = read_net(net_file)
    poses = []
    for index, (kind, name) in enumerate(names):
        if kind == "edge":
            edge = net.getEdge(name) if net.hasEdge(name) else None
            if edge is None:
                raise ValueError(index, f"no edge {name!r} in the network {net_file.name}")
            lanes = [lane for lane in edge.getLanes() if lane.allows("passenger")]
            if not lanes:
                raise ValueError(index, f"no lane of edge {name!r} allows passenger cars")
            lane = lanes[0]
        else:
            lane = _lane(net, name)
            if lane is None:
                raise ValueError(index, f"no lane {name!r} in the network {net_file.name}")
            if not lane.allows("passenger"):
                raise ValueError(index, f"lane {name!r} does not allow passenger cars")
        length = LineString(lane.getShape()).length
        if offset > length:
            raise ValueError(index, f"lane {lane.getID()!r} is {length:.1f} m long, shorter "
                             f"than start_offset = {offset:g} m")
        poses.append(_along(lane, offset))
    return poses


def anywhere_poses(net_file: Path, area: Polygon | MultiPolygon, length: float, width: float
                   ) -> list[tuple[float, float, float]]:
    """The starts of ``start_anywhere``: (x, y, heading) of the front-bumper point every
    ``ANYWHERE_SPACING_M`` along the centre line of every lane that allows passenger cars,
    facing each way, where a ``length`` x ``width`` body, stretched ``ANYWHERE_AHEAD_M``
    forwards, lies ``ANYWHERE_CLEARANCE_M`` inside ``area``."""
    inner = area.buffer(-ANYWHERE_CLEARANCE_M)
    corners = np.empty((4, 2))
    poses = []
    for edge in read_net(net_file).getEdges():
        for lane in edge.getLanes():
            if not lane.allows("passenger"):
                continue
            along = LineString(lane.getShape()).length
            for offset in np.arange(ANYWHERE_SPACING_M / 2, along, ANYWHERE_SPACING_M):
                x, y, heading = _along(lane, float(offset))
                for facing in (heading, heading + math.pi):
                    facing = math.remainder(facing, 2 * math.pi)
                    # the body with its front moved ANYWHERE_AHEAD_M forwards
                    reach = (ANYWHERE_AHEAD_M * math.cos(facing),
                             ANYWHERE_AHEAD_M * math.sin(facing))
                    body_corners(x + reach[0], y + reach[1], facing, length + ANYWHERE_AHEAD_M,
                                 width, corners)
                    if inner.contains(Polygon(corners)):
                        poses.append((x, y, facing))
    return poses


def lane_spots(net_file: Path, surface: Surface = "passenger", spacing: float = 5.0
               ) -> np.ndarray:
    """(S, 3): x, y and heading every ``spacing`` metres along the centre line of every lane
    of the surface outside junctions, facing its direction of travel: where learners re-enter
    a SUMO network (:class:`~enn_traffic.sim.sumo.crowd.SumoCrowd`), whatever share of its
    bounding box the roads fill."""
    spots = []
    for edge in read_net(net_file).getEdges():
        if edge.getFunction() == "internal":  # not inside junctions
            continue
        for lane in edge.getLanes():
            if not drives_on(lane, surface):
                continue
            shape = LineString(lane.getShape())
            along = np.arange(spacing / 2, shape.length, spacing)
            if not len(along):
                continue
            ahead = shapely.line_interpolate_point(shape, np.minimum(along + 0.1, shape.length))
            behind = shapely.line_interpolate_point(shape, np.maximum(along - 0.1, 0.0))
            points = shapely.get_coordinates(shapely.line_interpolate_point(shape, along))
            delta = shapely.get_coordinates(ahead) - shapely.get_coordinates(behind)
            spots.append(np.column_stack([points, np.arctan2(delta[:, 1], delta[:, 0])]))
    if not spots:
        raise InputError(f"no lane of the {surface!r} surface is longer than {spacing:g} m",
                         net_file)
    return np.concatenate(spots)


def lanes_at(net_file: Path, xy: np.ndarray, surface: Surface = "passenger",
             within: float = NEAREST_LANE_M) -> list[str]:
    """The SUMO lane of the surface nearest each point of ``xy`` (n, 2) (inside a junction,
    one of its internal lanes ``:NODE_…``), or "" where no lane's centre line is within
    ``within`` metres or the point is unknown (NaN): where on the network a life ended."""
    lanes = [lane for edge in read_net(net_file).getEdges() for lane in edge.getLanes()
             if drives_on(lane, surface)]
    found = [""] * len(xy)
    known = np.flatnonzero(np.isfinite(np.asarray(xy, dtype=np.float64)).all(axis=1))
    if not lanes or not len(known):
        return found
    tree = shapely.STRtree([LineString(lane.getShape()) for lane in lanes])
    points, nearest = tree.query_nearest(shapely.points(np.asarray(xy)[known]),
                                         max_distance=within, all_matches=False)
    for point, lane in zip(points.tolist(), nearest.tolist(), strict=True):
        found[int(known[point])] = lanes[lane].getID()
    return found


def _lane(net: sumolib.net.Net, lane_id: str):
    """The lane ``EDGE_INDEX``, or None."""
    edge_id, _, index = lane_id.rpartition("_")
    if not net.hasEdge(edge_id) or not index.isdigit():
        return None
    lanes = net.getEdge(edge_id).getLanes()
    return lanes[int(index)] if int(index) < len(lanes) else None


def _along(lane, offset: float) -> tuple[float, float, float]:
    """(x, y, heading) ``offset`` metres along a lane's centre line (clipped to its length)."""
    shape = LineString(lane.getShape())
    offset = min(max(offset, 0.0), shape.length)
    point = shape.interpolate(offset)
    ahead = shape.interpolate(min(offset + 0.1, shape.length))
    behind = shape.interpolate(max(offset - 0.1, 0.0))
    heading = math.atan2(ahead.y - behind.y, ahead.x - behind.x)
    return point.x, point.y, heading


def read_net(path: Path) -> sumolib.net.Net:
    """The SUMO network ``path`` (its internal lanes too), read once per process while the
    file is unchanged; a clear InputError if it is missing or unreadable."""
    check_input_file(path, "network file")
    return _read_net(path.resolve(), *file_stamp(path))


@functools.lru_cache(maxsize=2)
def _read_net(path: Path, *stamp: int) -> sumolib.net.Net:
    problem = xml_problem(path, *stamp)  # SUMO and sumolib take minutes on some such files
    if problem:
        raise InputError(f"not a readable SUMO network: {problem}", path)
    try:
        net = read_sumo_net(path, withInternal=True)
    except ElementTree.ParseError as exc:
        raise InputError(f"not a readable SUMO network: {exc}", path) from None
    except Exception as exc:  # sumolib raises plain exceptions on malformed nets
        message = f"not a readable SUMO network: {type(exc).__name__}: {exc}"
        raise InputError(message, path) from None
    _check_whole(net, path)
    return net


def _check_whole(net: sumolib.net.Net, path: Path) -> None:
    """An InputError naming the first junction an edge names that the file does not hold
    (sumolib makes one up, with no position), or the first junction or lane whose position
    or shape holds a coordinate that is not a number."""
    for node in net.getNodes():
        if node._coord is None:  # sumolib's own record: getCoord() fails on it
            raise InputError(f"junction {node.getID()!r}, which its edges name, is not in the "
                             "file (a network cut short, or edited by hand?)", path)
        if not all(math.isfinite(value) for value in node._coord[:2]):
            raise InputError(f"junction {node.getID()!r}: its position is not a number", path)
        if not all(math.isfinite(value) for point in node.getShape() for value in point[:2]):
            raise InputError(f"junction {node.getID()!r}: its shape holds a coordinate that "
                             "is not a number", path)
    for edge in net.getEdges(withInternal=True):
        for lane in edge.getLanes():
            if not all(math.isfinite(value) for point in lane.getShape() for value in point[:2]):
                raise InputError(f"lane {lane.getID()!r}: its shape holds a coordinate that "
                                 "is not a number", path)


def drives_on(lane, surface: Surface) -> bool:
    """Is ``lane`` road surface: every lane for ``"all"``, else one that allows passenger
    cars?"""
    return surface == "all" or lane.allows(LEARNER_CLASS)


def drivable_area(net: sumolib.net.Net, surface: Surface = "passenger"
                  ) -> Polygon | MultiPolygon:
    """Union of the lane and junction shapes of ``net`` that are road for ``surface``: with
    ``"passenger"``, the lanes that allow passenger cars, and the junctions that such a lane
    meets, less their walking areas (sidewalk corners); with ``"all"``, every one."""
    pieces, walking = [], []
    for edge in net.getEdges(withInternal=True):
        if surface != "all" and edge.getFunction() == "walkingarea":
            walking += [_polygon(lane.getShape()) for lane in edge.getLanes()
                        if len(lane.getShape()) >= 3]
            continue
        for lane in edge.getLanes():
            shape = lane.getShape()
            if len(shape) >= 2 and drives_on(lane, surface):
                pieces.append(
                    LineString(shape).buffer(
                        lane.getWidth() / 2, cap_style="flat", join_style="mitre"
                    )
                )
    junctions = []
    for node in net.getNodes():
        shape = node.getShape() or []  # None: a node its edges name, with no <junction>
        if len(shape) >= 3 and _meets_road(node, surface):
            junctions.append(_polygon(shape))
    if walking:  # the junctions' own corners of sidewalk are not road
        junctions = [_junction_road(junctions, walking, pieces)]
    pieces += junctions
    # Close the gaps between abutting shapes (netconvert rounds coordinates to 0.01 m, so a
    # lane can miss its junction by a few millimetres at a sharp bend), then drop collinear
    # vertices.
    area = unary_union(pieces).buffer(SNAP_M, join_style="mitre").buffer(
        -SNAP_M, join_style="mitre"
    ).simplify(1e-3)
    return _without_slivers(area)


def _junction_road(junctions: list, walking: list, lanes: list) -> Polygon | MultiPolygon:
    """The junctions less their walking areas, without what that leaves thinner than
    ``2 * REMNANT_M`` (slivers along a walking area's edge) and without the pieces that
    touch no lane of the road."""
    rest = unary_union(junctions).difference(unary_union(walking))
    rest = rest.buffer(-REMNANT_M, join_style="mitre").buffer(REMNANT_M, join_style="mitre")
    road = unary_union(lanes)
    parts = list(rest.geoms) if hasattr(rest, "geoms") else [rest]
    return unary_union([part for part in parts if part.intersects(road)])


def _polygon(shape) -> Polygon:
    polygon = Polygon(shape)
    return polygon if polygon.is_valid else polygon.buffer(0)


def _meets_road(node, surface: Surface) -> bool:
    """Does a road lane (:func:`drives_on`) start or end at ``node``?"""
    return surface == "all" or any(
        drives_on(lane, surface) for edge in (*node.getIncoming(), *node.getOutgoing())
        for lane in edge.getLanes())


def _without_slivers(area: Polygon | MultiPolygon) -> Polygon | MultiPolygon:
    """``area`` without its holes narrower than ``SLIVER_M`` (width ~ 2 area / perimeter)."""
    polygons = list(area.geoms) if isinstance(area, MultiPolygon) else [area]
    kept = []
    for polygon in polygons:
        holes = [ring for ring in polygon.interiors
                 if 2.0 * Polygon(ring).area / ring.length >= SLIVER_M]
        kept.append(Polygon(polygon.exterior, holes))
    return kept[0] if len(kept) == 1 else MultiPolygon(kept)


def _fringe(net: sumolib.net.Net, surface: Surface) -> list[tuple[object, list]]:
    """The fringe's nodes (a single neighbouring node by road, :func:`drives_on`), each with
    its road edges and whether each leaves the node (True) or reaches it."""

    def road(edges):
        return [e for e in edges if e.getFunction() != "internal"
                and any(drives_on(lane, surface) for lane in e.getLanes())]

    fringe = []
    for node in net.getNodes():
        edges = [(e, True) for e in road(node.getOutgoing())]
        edges += [(e, False) for e in road(node.getIncoming())]
        neighbours = {(e.getToNode() if out else e.getFromNode()).getID() for e, out in edges}
        neighbours.discard(node.getID())
        if len(neighbours) == 1:
            fringe.append((node, edges))
    return fringe


def fringe_nodes(net: sumolib.net.Net, surface: Surface = "passenger") -> set[str]:
    """The ids of the network's fringe nodes (:func:`fringe_mouths`): an edge that ends at one
    leads out of the network, or into a dead end."""
    return {node.getID() for node, _ in _fringe(net, surface)}


def fringe_mouths(net: sumolib.net.Net, surface: Surface = "passenger"
                  ) -> list[tuple[np.ndarray, np.ndarray, float, float]]:
    """The road ends at the network's fringe, one per node with a single neighbouring node
    by road (:func:`drives_on`): (a point on the mouth line, the unit direction into the
    network, the mouth's extent across the road from that point: lowest and highest, lane
    edges included)."""
    mouths = []
    for node, edges in _fringe(net, surface):
        ends, inward, widths = [], [], []
        for edge, out in edges:
            for lane in edge.getLanes():
                if not drives_on(lane, surface):
                    continue
                shape = np.asarray(lane.getShape(), dtype=np.float64)
                end, nxt = (shape[0], shape[1]) if out else (shape[-1], shape[-2])
                ends.append(end)
                inward.append((nxt - end) / max(np.linalg.norm(nxt - end), 1e-9))
                widths.append(lane.getWidth())
        if not ends:
            continue
        u = np.sum(inward, axis=0)
        u /= max(np.linalg.norm(u), 1e-9)
        n = np.array([-u[1], u[0]])
        centre = np.asarray(node.getCoord(), dtype=np.float64)
        # The mouth lies where the innermost lane ends, so that every lane reaches it.
        along = max(float((end - centre) @ u) for end in ends)
        across = [float((end - centre) @ n) for end in ends]
        low = min(a - w / 2 for a, w in zip(across, widths, strict=True))
        high = max(a + w / 2 for a, w in zip(across, widths, strict=True))
        mouths.append((centre + along * u, u, low, high))
    return mouths


def _open_fringe(area, net, surface: Surface = "passenger"
                 ) -> tuple[Polygon | MultiPolygon, np.ndarray, list]:
    """``area`` cut open at every fringe mouth (whatever lies beyond a mouth, such as a
    turnaround, is removed), the mouths' lines (M, 4), and the mouths."""
    mouths = fringe_mouths(net, surface)
    cuts, lines = [], []
    for point, u, low, high in mouths:
        n = np.array([-u[1], u[0]])
        depth = max(10.0, 2.0 * (high - low))
        a, b = point + (low - EXIT_MARGIN_M) * n, point + (high + EXIT_MARGIN_M) * n
        cuts.append(Polygon([a, b, b - depth * u, a - depth * u]))
        lines.append([*a, *b])
    if cuts:
        area = area.difference(unary_union(cuts)).simplify(1e-3)
    return area, np.asarray(lines, dtype=np.float64).reshape(-1, 4), mouths


def split_exits(segments: np.ndarray, mouth_lines: np.ndarray, tolerance: float = 1e-2
                ) -> tuple[np.ndarray, np.ndarray]:
    """Boundary segments that lie on a mouth line (exits), and the rest (walls)."""
    on_mouth = np.zeros(len(segments), dtype=bool)
    for x1, y1, x2, y2 in mouth_lines:
        d = np.array([x2 - x1, y2 - y1])
        length = np.linalg.norm(d)
        d /= length
        first, second = segments[:, 0:2] - (x1, y1), segments[:, 2:4] - (x1, y1)
        off = np.maximum(np.abs(first @ (-d[1], d[0])), np.abs(second @ (-d[1], d[0])))
        inside = ((first @ d >= -tolerance) & (first @ d <= length + tolerance)
                  & (second @ d >= -tolerance) & (second @ d <= length + tolerance))
        on_mouth |= (off <= tolerance) & inside
    return segments[on_mouth], segments[~on_mouth]


def boundary_segments(area: Polygon | MultiPolygon) -> np.ndarray:
    """Every edge of the boundary of ``area`` as rows ``x1, y1, x2, y2``."""
    polygons = list(area.geoms) if isinstance(area, MultiPolygon) else [area]
    rows = []
    for polygon in polygons:
        for ring in (polygon.exterior, *polygon.interiors):
            xy = np.asarray(ring.coords)
            rows.append(np.hstack([xy[:-1], xy[1:]]))
    return np.vstack(rows) if rows else np.empty((0, 4))


def load_track(net_file: str | Path, exits: bool = False, surface: Surface = "passenger"
               ) -> Track:
    """Read a SUMO network and return its walls (and, with ``exits``, its fringe cut open
    into exits) for the road ``surface``; a clear :class:`InputError` if it has no drivable
    area. Built once per network file (by its bytes) and kept on disk."""
    path = Path(net_file)
    check_input_file(path, "network file")
    key = cache.key_of(cache.file_digest(path), exits, surface, WALLS_VERSION, SNAP_M,
                       SLIVER_M, EXIT_MARGIN_M, shapely.__version__, sumolib.__version__)

    def build() -> dict[str, np.ndarray]:
        with slow_step(f"building the walls of {path.name}"):
            track = _build_track(path, exits, surface)
        return {"walls": track.walls, "exits": track.exits,
                "area": np.frombuffer(shapely.to_wkb(track.area), dtype=np.uint8)}

    arrays = cache.cached_arrays("walls", key, build)
    return Track(name=_track_name(path), walls=arrays["walls"],
                 area=shapely.from_wkb(arrays["area"].tobytes()), exits=arrays["exits"])


def _track_name(path: Path) -> str:
    return path.name.removesuffix(".gz").removesuffix(".xml").removesuffix(".net")


def _build_track(path: Path, exits: bool, surface: Surface) -> Track:
    net = read_net(path)
    area = drivable_area(net, surface)
    if area.is_empty or area.area <= 0:
        what = "no lanes or junctions" if surface == "all" else "no lane allows passenger cars"
        raise InputError(f"the network has no drivable area ({what})", path)
    name = _track_name(path)
    if not exits:
        return Track(name=name, walls=boundary_segments(area), area=area)
    area, mouth_lines, _ = _open_fringe(area, net, surface)
    exit_segments, walls = split_exits(boundary_segments(area), mouth_lines)
    return Track(name=name, walls=walls, area=area, exits=exit_segments)
