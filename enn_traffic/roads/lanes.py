"""The lanes a learner may start on, ranked by the traffic the demand sends over them
(``enn-traffic lanes``; ``[track] start_lane = "auto"``; docs/sumo.md, "Choosing a start
lane").

The demand is read from the route files as published: a vehicle or flow with a route counts on
each edge of it; a trip or a flow between edges (``from``, ``via``, ``to``) is routed by SUMO's
own ``duarouter`` on the network, as SUMO routes it when it departs, and counts on every edge
of that route (where ``duarouter`` finds none, on its given edges only). A flow counts its
vehicles: ``number``, or its span over ``period``, ``vehsPerHour`` or ``probability`` (a flow
without an ``end`` counts one hour). The counts are kept in the cache folder, named by the
files' bytes (:mod:`enn_traffic.core.cache`).

A lane's share of its edge's demand follows SUMO's strategic lane choice: a vehicle drives on
the lanes of an edge that allow its class (its type's ``vClass``, from the route and additional
files; passenger when not given, as SUMO's) and connect to the next edge of its route, one
share each (all of the edge's lanes it may use on its route's last edge, or where none
connects). SUMO spreads vehicles over equally good lanes as it drives, so such lanes tie.

A lane whose edge ends at the network's fringe (an exit: the learner would leave the network
within the lane's length) is never a learner's lane for ``auto``.
"""

from __future__ import annotations

import shutil
import subprocess
import tempfile
import xml.etree.ElementTree as ElementTree
from collections import Counter
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pandas as pd

from enn_traffic.core.cache import cached_arrays, content_digest, key_of
from enn_traffic.core.errors import InputError
from enn_traffic.core.progress import slow_step
from enn_traffic.roads.network import LEARNER_CLASS, fringe_nodes, read_net
from enn_traffic.roads.sumocfg import parse_time
from enn_traffic.roads.xmlread import iterparse, open_xml

# The vehicle classes the ``allowed`` column names (of SUMO's 41), in this order.
SHOWN_CLASSES = ("passenger", "taxi", "bus", "delivery", "truck", "motorcycle", "bicycle",
                 "pedestrian", "tram", "rail_urban", "rail")
UNBOUNDED_FLOW_S = 3600.0  # a flow without an end counts this long


def _flow_vehicles(element: ElementTree.Element) -> float:
    """How many vehicles a ``<flow>`` sends."""
    if element.get("number") is not None:
        return float(element.get("number"))
    begin = parse_time(element.get("begin", "0"))
    end = element.get("end")
    span = parse_time(end) - begin if end is not None else UNBOUNDED_FLOW_S
    if element.get("period") is not None:
        period = element.get("period")
        if period.startswith("exp("):  # a Poisson flow of this rate per second
            return span * float(period[4:-1])
        return span / max(parse_time(period), 1e-9)
    for rate, per in (("vehsPerHour", 3600.0), ("perHour", 3600.0), ("probability", 1.0)):
        if element.get(rate) is not None:
            return span * float(element.get(rate)) / per
    return 1.0


def vehicle_classes(files: list[Path] | tuple[Path, ...]) -> dict[str, str]:
    """The vehicle class of each vehicle type (and type distribution: its first type's) that
    the files define."""
    classes: dict[str, str] = {}
    for path in files:
        try:
            with open_xml(path) as handle:
                for _, element in iterparse(handle):
                    if element.tag == "vType":  # kept whole: a distribution may hold it
                        if element.get("id"):
                            classes[element.get("id")] = element.get("vClass", "passenger")
                        continue
                    if element.tag == "vTypeDistribution" and element.get("id"):
                        first = element.find("vType")
                        named = (element.get("vTypes") or "").split()
                        classes[element.get("id")] = (
                            first.get("vClass", "passenger") if first is not None
                            else classes.get(named[0], "passenger") if named else "passenger")
                    if element.tag != "param":
                        element.clear()
        except (ElementTree.ParseError, OSError) as exc:
            raise InputError(f"not a readable SUMO file: {exc}", path) from None
    return classes


def demand_per_edge(route_files: list[Path] | tuple[Path, ...],
                    classes: dict[str, str] | None = None,
                    net_file: Path | None = None) -> Counter[tuple[str, str]]:
    """Vehicles the route files send over each edge, by vehicle class: (edge, class) ->
    vehicles (:func:`demand_per_move` summed over the next edges)."""
    demand: Counter[tuple[str, str]] = Counter()
    for (edge, _, kind), vehicles in demand_per_move(route_files, classes, net_file).items():
        demand[edge, kind] += vehicles
    return demand


def demand_per_move(route_files: list[Path] | tuple[Path, ...],
                    classes: dict[str, str] | None = None,
                    net_file: Path | None = None) -> Counter[tuple[str, str, str]]:
    """Vehicles the route files send over each edge, by the edge they drive on to ("" at the
    route's end, or for a trip counted on its given edges) and vehicle class: (edge, next
    edge, class) -> vehicles (see the module's docstring), once per vehicle and edge (a route
    that passes an edge twice counts its first move on). ``classes``: each vehicle type's
    class, besides those the route files define. With ``net_file``, trips and flows between
    edges are routed on it by ``duarouter`` (:func:`_route_trips`); without, they count on
    their given edges."""
    classes = {**(classes or {}), **vehicle_classes(route_files)}
    routes: dict[str, list[tuple[list[str], float]]] = {}  # a route or distribution's routes
    demand: Counter[tuple[str, str, str]] = Counter()
    types: list[bytes] = []  # every vType and vTypeDistribution, for duarouter
    unrouted: list[bytes] = []  # trips and flows between edges

    def count(element: ElementTree.Element, vehicles: float) -> None:
        kind = classes.get(element.get("type", "DEFAULT_VEHTYPE"), "passenger")
        inner = element.find("route")
        if inner is not None:
            paths = [(inner.get("edges", "").split(), 1.0)]
        elif element.get("route") in routes:
            paths = routes[element.get("route")]
        else:  # a trip, or a flow between edges
            if net_file is not None and element.get("from") and element.get("to"):
                unrouted.append(ElementTree.tostring(element))
                return
            given = [element.get(k) for k in ("from", "to") if element.get(k)]
            for edge in dict.fromkeys(given + element.get("via", "").split()):
                demand[edge, "", kind] += vehicles  # no path: no next edge
            return
        total = sum(weight for _, weight in paths) or 1.0
        for edges, weight in paths:
            moves: dict[str, str] = {}
            for edge, after in zip(edges, [*edges[1:], ""], strict=True):
                moves.setdefault(edge, after)  # once per vehicle, however often it passes
            for edge, after in moves.items():
                demand[edge, after, kind] += vehicles * weight / total

    for path in route_files:
        try:
            with open_xml(path) as handle:
                depth = 0
                for event, element in iterparse(handle, ("start", "end")):
                    if event == "start":
                        depth += 1
                        continue
                    depth -= 1
                    if depth != 1:
                        continue  # a top-level element is handled whole, at its end
                    tag = element.tag
                    if tag == "route" and element.get("id"):
                        routes[element.get("id")] = [(element.get("edges", "").split(), 1.0)]
                    elif tag == "routeDistribution" and element.get("id"):
                        routes[element.get("id")] = [
                            (r.get("edges", "").split(), float(r.get("probability", "1")))
                            for r in element.findall("route") if r.get("edges")]
                    elif tag in ("vType", "vTypeDistribution"):
                        types.append(ElementTree.tostring(element))
                    elif tag in ("vehicle", "trip"):
                        count(element, 1.0)
                    elif tag == "flow":
                        count(element, _flow_vehicles(element))
                    element.clear()
        except (ElementTree.ParseError, OSError, ValueError) as exc:
            raise InputError(f"not a readable SUMO route file: {exc}", path) from None
    if unrouted:
        routed = _route_trips(net_file, types, unrouted)
        try:
            demand.update(demand_per_move([routed], classes))
        finally:
            shutil.rmtree(routed.parent, ignore_errors=True)
    return demand


DUAROUTER_MAX_S = 600.0


def _route_trips(net_file: Path, types: list[bytes], trips: list[bytes]) -> Path:
    """The ``trips`` (trip and flow elements between edges) routed on the network by SUMO's
    ``duarouter``, as SUMO routes them (fastest path at free flow), into a temporary route
    file, in a temporary folder of its own that the caller removes; one it cannot route is
    left out with a warning, and counts nowhere."""
    import sumo as sumo_wheel  # duarouter of the eclipse-sumo wheel

    folder = Path(tempfile.mkdtemp(prefix="enn-routes-"))
    given, routed = folder / "trips.xml", folder / "routes.xml"
    given.write_bytes(b"<routes>\n" + b"\n".join(types + trips) + b"\n</routes>\n")
    with slow_step(f"routing {len(trips):,} trips and flows of the demand on "
                   f"{Path(net_file).name} (SUMO's duarouter), to count where they drive"):
        done = subprocess.run(
            [f"{sumo_wheel.SUMO_HOME}/bin/duarouter", "-n", str(net_file), "-r", str(given),
             "-o", str(routed), "--ignore-errors", "true", "--unsorted-input", "true",
             "--no-step-log", "true", "--no-warnings", "true", "--routing-threads", "1"],
            capture_output=True, text=True, timeout=DUAROUTER_MAX_S, check=False)
    given.unlink()
    if done.returncode != 0 or not routed.is_file():
        shutil.rmtree(folder, ignore_errors=True)
        raise InputError(f"SUMO's duarouter could not route the demand's trips: "
                         f"{' '.join((done.stderr or done.stdout).split())[:400]}", net_file)
    return routed


DEMAND_VERSION = 2  # raised when the counting changes


def cached_demand(net_file: Path, route_files: list[Path] | tuple[Path, ...],
                  additional_files: list[Path] | tuple[Path, ...] = ()
                  ) -> Counter[tuple[str, str, str]]:
    """:func:`demand_per_move` with the trips routed on ``net_file``, counted once and kept in
    the cache folder (named by every file's bytes)."""
    key = key_of(DEMAND_VERSION, content_digest(net_file),
                 *(content_digest(f) for f in (*route_files, *additional_files)))

    def build() -> dict[str, np.ndarray]:
        demand = demand_per_move(route_files, vehicle_classes(additional_files), net_file)
        pairs = list(demand.items())
        return {"edges": np.array([edge for (edge, _, _), _ in pairs], dtype=str),
                "next": np.array([after for (_, after, _), _ in pairs], dtype=str),
                "classes": np.array([kind for (*_, kind), _ in pairs], dtype=str),
                "vehicles": np.array([v for _, v in pairs], dtype=np.float64)}

    with slow_step(f"counting the demand over {Path(net_file).name}'s lanes"):
        arrays = cached_arrays("demand", key, build)
    return Counter({(str(e), str(n), str(k)): float(v) for e, n, k, v
                    in zip(arrays["edges"], arrays["next"], arrays["classes"],
                           arrays["vehicles"], strict=True)})


def _allowed(lane) -> str:
    """The lane's vehicle classes of :data:`SHOWN_CLASSES`: ``all``, ``all but ...`` (up to
    three missing) or those it allows."""
    permissions = lane.getPermissions()
    missing = [c for c in SHOWN_CLASSES if c not in permissions]
    if not missing:
        return "all"
    if len(missing) <= 3:
        return "all but " + " ".join(missing)
    return " ".join(c for c in SHOWN_CLASSES if c in permissions)


def lane_table(net_file: Path, route_files: list[Path] | tuple[Path, ...],
               additional_files: list[Path] | tuple[Path, ...] = (),
               min_length: float = 0.0, exits: bool = True) -> pd.DataFrame:
    """Every lane of the network (internal ones excepted): its edge, length, speed limit (km/h),
    allowed classes (of :data:`SHOWN_CLASSES`), whether its edge ends at an exit (the
    network's fringe, with ``exits``), whether the learner may start on it (it allows
    passenger cars, is ``min_length`` long or longer,
    :func:`~enn_traffic.roads.network.least_start_length`, and does not end at an exit), the
    demand's vehicles over its edge of the classes it allows (``edge_vehicles``) and its share
    of them (``vehicles``: the module's docstring), expected counts to one decimal; the
    learner's lanes first, ranked by their share, then by length, then name.
    ``additional_files``: where vehicle types may be defined too."""
    with slow_step(f"reading {Path(net_file).name}"):
        net = read_net(net_file)
    demand: dict[str, list[tuple[str, str, float]]] = {}
    for (edge, after, kind), vehicles in cached_demand(net_file, route_files,
                                                       additional_files).items():
        demand.setdefault(edge, []).append((after, kind, vehicles))
    fringe = fringe_nodes(net) if exits else set()

    rows = []
    for edge in net.getEdges(withInternal=False):
        at_exit = edge.getToNode().getID() in fringe
        shares = lane_shares(edge, demand.get(edge.getID(), []))
        edge_vehicles = {lane.getID(): round(sum(
            v for _, kind, v in demand.get(edge.getID(), []) if lane.allows(kind)), 1)
            for lane in edge.getLanes()}
        for lane in edge.getLanes():
            cars = lane.allows(LEARNER_CLASS)
            rows.append({
                "lane": lane.getID(), "edge": edge.getID(),
                "vehicles": round(shares.get(lane.getID(), 0.0), 1),
                "edge_vehicles": edge_vehicles[lane.getID()],
                "length_m": round(lane.getLength(), 1),
                "speed_limit_kmh": round(3.6 * lane.getSpeed()), "allowed": _allowed(lane),
                "ends_at_fringe": at_exit, "allows_cars": cars,
                "learner_may_start": cars and lane.getLength() >= min_length and not at_exit})
    table = pd.DataFrame(rows, columns=["lane", "edge", "vehicles", "edge_vehicles",
                                        "length_m", "speed_limit_kmh", "allowed",
                                        "ends_at_fringe", "allows_cars", "learner_may_start"])
    table["vehicles"] = table["vehicles"].astype(np.float64)
    table["edge_vehicles"] = table["edge_vehicles"].astype(np.float64)
    table = table.sort_values(["learner_may_start", "vehicles", "length_m", "lane"],
                              ascending=[False, False, False, True], kind="stable")
    return table.reset_index(drop=True)


def lane_shares(edge, moves: list[tuple[str, str, float]]) -> dict[str, float]:
    """Each lane's share of the ``moves`` (next edge, vehicle class, vehicles) over ``edge``
    (a sumolib edge): a move's vehicles split evenly over the lanes that allow their class and
    connect to the next edge, or, where none does, over all that allow it (the module's
    docstring)."""
    onward: dict[str, set[str]] = {}  # next edge -> the lanes that connect to it
    for after, connections in edge.getOutgoing().items():
        onward[after.getID()] = {c.getFromLane().getID() for c in connections}
    shares: dict[str, float] = {}
    for after, kind, vehicles in moves:
        allowed = [lane.getID() for lane in edge.getLanes() if lane.allows(kind)]
        lanes = [lane for lane in allowed if lane in onward.get(after, ())] or allowed
        for lane in lanes:
            shares[lane] = shares.get(lane, 0.0) + vehicles / len(lanes)
    return shares


def auto_lane(net_file: Path, route_files: list[Path] | tuple[Path, ...],
              min_length: float, additional_files: list[Path] | tuple[Path, ...] = (),
              exits: bool = True, clear: Callable[[str], bool] | None = None) -> str:
    """``start_lane = "auto"``: the learner's lane that the demand uses most, among those at
    least ``min_length`` long whose edge does not end at an exit and, with ``clear``
    (:func:`~enn_traffic.roads.network.clear_starts`), whose start leaves the body on the
    road (an InputError if there is none)."""
    table = lane_table(net_file, route_files, additional_files, min_length, exits)
    fit = table[table["learner_may_start"]]
    for lane in fit["lane"]:
        if clear is None or clear(str(lane)):
            return str(lane)
    raise InputError(f"no lane that allows passenger cars is {min_length:g} m long or longer"
                     + (" and does not end at the network's fringe" if exits else "")
                     + (" and leaves the body on the road at its start" if len(fit) else ""),
                     net_file)
