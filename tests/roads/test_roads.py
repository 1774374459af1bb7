import warnings

import numpy as np
import pytest
from shapely.geometry import LineString, Polygon

from enn_traffic.core.errors import InputError
from enn_traffic.roads import load_track

# docs/design.md, "The authors' code" 1: the authors' narrow track, start vertex and 57 moves
AUTHORS_MOVES = [12, 30, 30, 30, -80, 30, 30, 80, -30, -40, -30, 80, 80, 30, -200, -30, 40, -30,
                 -80, -30, 40, -60, 30, 60, 30, -80, -80, -80, 12, 68, 80, 104, -54, -60, -6,
                 60, -40, 6, 80, 54, -40, 6, 176, -6, -80, -104, 54, 40, 6, -56, -30, -54, 80,
                 -6, -30, -42, 12]


def authors_polyline():
    points = [(-8.0, -20.0)]
    for i, move in enumerate(AUTHORS_MOVES):
        x, y = points[-1]
        points.append((x + move, y) if i % 2 == 0 else (x, y + move))
    return points


def test_narrow_track_walls_follow_the_authors_polyline(root):
    track = load_track(root / "sumo_nets" / "track_narrow.net.xml")
    reference = LineString(authors_polyline())
    wall_points = np.vstack([track.walls[:, :2], track.walls[:, 2:]])
    # every wall vertex within 0.5 m of the polyline, and every polyline vertex within 0.5 m
    # of a wall, and the same enclosed area
    walls = [LineString([w[:2], w[2:]]) for w in track.walls]
    assert max(reference.distance(LineString([p, p])) for p in wall_points) < 0.5
    assert max(min(w.distance(LineString([p, p])) for w in walls)
               for p in authors_polyline()) < 0.5
    assert track.area.area == pytest.approx(Polygon(authors_polyline()[:-1]).area, rel=1e-3)


def test_arena_is_a_100m_square(root):
    track = load_track(root / "sumo_nets" / "arena.net.xml")
    assert track.bounds == pytest.approx((0, 0, 100, 100))
    assert track.area.area == pytest.approx(10_000)
    assert len(track.walls) == 4


def test_wide_track_is_the_narrow_course_scaled(root):
    narrow = load_track(root / "sumo_nets" / "track_narrow.net.xml")
    wide = load_track(root / "sumo_nets" / "track_wide.net.xml")
    assert wide.area.area == pytest.approx(narrow.area.area * 2.5**2, rel=1e-3)


def test_every_shipped_network_loads_into_one_area(root):
    for net in sorted((root / "sumo_nets").glob("*.net.xml")):
        track = load_track(net)
        assert track.area.geom_type == "Polygon", net.name
        assert len(track.walls) >= 4


def test_broken_network_is_a_clear_error(tmp_path):
    broken = tmp_path / "broken.net.xml"
    broken.write_text("<net><edge id='e'><lane id='e_0' shape='0,0 10,0'")
    with pytest.raises(InputError, match="not a readable SUMO network") as info:
        load_track(broken)
    assert "broken.net.xml" in str(info.value)


def test_missing_network_and_empty_network(tmp_path):
    with pytest.raises(InputError, match="not found"):
        load_track(tmp_path / "absent.net.xml")
    empty = tmp_path / "empty.net.xml"
    empty.write_text('<net version="1.20"><location netOffset="0,0" convBoundary="0,0,1,1" '
                     'origBoundary="0,0,1,1" projParameter="!"/></net>')
    with pytest.raises(InputError, match="no drivable area"):
        load_track(empty)


def test_coverage_counts_the_cells_a_path_enters(root):
    """The arena is 10 x 10 cells of 10 m: a straight crossing enters one row of them."""
    track = load_track(root / "sumo_nets" / "arena.net.xml")
    across = np.column_stack([np.linspace(0.5, 99.5, 200), np.full(200, 55.0)])
    assert track.coverage(across, cell=10.0) == pytest.approx(0.1)
    assert track.coverage(np.vstack([across, across[::-1]]), cell=10.0) == pytest.approx(0.1)
    circle = 50 + 3 * np.column_stack([np.cos(np.arange(300)), np.sin(np.arange(300))])
    assert track.coverage(circle, cell=10.0) == pytest.approx(0.04)  # the 4 cells round (50, 50)
    assert track.coverage(np.array([[-50.0, -50.0]]), cell=10.0) == 0.0


def test_mixed_tracks_have_their_widths(root):
    """Each corridor of sumo_nets/build.py is as wide as it says: its area is its width times
    its centre line's length, to within the junctions' rounded corners."""
    import importlib.util

    spec = importlib.util.spec_from_file_location("build", root / "sumo_nets" / "build.py")
    build = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(build)
    for name, corridor in build.MIXED_TRACKS.items():
        points = corridor["points"] + (corridor["points"][:1] if corridor.get("closed") else [])
        length = LineString(points).length
        area = load_track(root / "sumo_nets" / f"{name}.net.xml").area.area
        assert area == pytest.approx(corridor["width"] * length, rel=0.04), name


def test_walls_and_grid_are_kept_and_built_again_when_the_network_changes(root, tmp_path,
                                                                          monkeypatch):
    """A network's walls and wall grid are built once and then read from the cache folder,
    identical; a changed network file is built again; a cache folder that cannot be written
    costs time, not an error."""
    from enn_traffic.sim.sensors import WallGrid

    monkeypatch.setenv("ENN_TRAFFIC_CACHE", str(tmp_path / "cache"))
    net = tmp_path / "narrow.net.xml"
    net.write_bytes((root / "sumo_nets" / "track_narrow.net.xml").read_bytes())
    first = load_track(net, exits=False)
    grid = WallGrid.cached(first.walls, 26.0)
    entries = sorted((tmp_path / "cache").rglob("*.npz"))
    assert [e.parent.name for e in entries] == ["grids", "walls"]
    again = load_track(net, exits=False)
    np.testing.assert_array_equal(again.walls, first.walls)
    assert again.area.equals_exact(first.area, 0)
    kept = WallGrid.cached(again.walls, 26.0)
    for name in ("cell_start", "cell_walls"):
        np.testing.assert_array_equal(getattr(kept, name), getattr(grid, name))
    assert (kept.cells_x, kept.cell_x0) == (grid.cells_x, grid.cell_x0)
    assert sorted((tmp_path / "cache").rglob("*.npz")) == entries  # nothing built again
    net.write_text(net.read_text().replace('width="12.00"', 'width="11.00"', 1))
    load_track(net, exits=False)
    assert len(list((tmp_path / "cache" / "walls").glob("*.npz"))) == 2
    blocked = tmp_path / "blocked"
    blocked.write_text("a file where the cache folder should be")
    monkeypatch.setenv("ENN_TRAFFIC_CACHE", str(blocked))
    np.testing.assert_array_equal(load_track(net, exits=False).walls,
                                  load_track(net, exits=False).walls)


def test_lane_spots_lie_along_each_lane_facing_its_traffic(root):
    """The ring's start lane: its first spot is 2.5 m along its centre line, facing along it
    (:meth:`Track.lane_pose`), its spots 5 m apart; every spot of the network lies on the
    drivable area, and there are as many as whole 5 m stretches of lane shape (plus one per
    lane at most)."""
    import sumolib

    from enn_traffic.roads.network import lane_spots

    net_file = root / "sumo_nets" / "sumo_ring.net.xml"
    track = load_track(net_file)
    spots = lane_spots(net_file)
    x, y, heading = track.lane_pose(net_file, "g0_0to1_0_2", 2.5)
    first = np.flatnonzero(np.hypot(spots[:, 0] - x, spots[:, 1] - y) < 1e-6)
    assert len(first) == 1
    assert spots[first[0], 2] == pytest.approx(heading)
    following = spots[first[0] + 1]
    assert np.hypot(following[0] - x, following[1] - y) == pytest.approx(5.0)
    assert all(track.contains(sx, sy) for sx, sy, _ in spots)
    lengths = [LineString(lane.getShape()).length
               for edge in sumolib.net.readNet(str(net_file)).getEdges()
               for lane in edge.getLanes() if lane.allows("passenger")]
    assert sum(int(length // 5) for length in lengths) <= len(spots) <= sum(
        int(length // 5) + 1 for length in lengths)


def test_lanes_at_names_the_lane_under_a_point_and_none_off_the_road(root):
    """A point 1 m beside the ring's start lane's centre line, 20 m along it, is on that lane;
    a point 50 m outside the network's bounds, and an unknown (NaN) one, are on none."""
    from enn_traffic.roads.network import lanes_at

    net_file = root / "sumo_nets" / "sumo_ring.net.xml"
    track = load_track(net_file)
    x, y, heading = track.lane_pose(net_file, "g0_0to1_0_2", 20.0)
    beside = (x - np.sin(heading), y + np.cos(heading))  # 1 m to the left of the centre line
    x0, y0, _, _ = track.bounds
    points = np.array([beside, (x0 - 50.0, y0 - 50.0), (np.nan, np.nan)])
    assert lanes_at(net_file, points) == ["g0_0to1_0_2", "", ""]


@pytest.mark.parametrize("edit, message", [
    # a lane's first coordinate not a number: shapely warned, then the start was "off the road"
    (lambda text: text.replace('<lane id="e0_0" index="0" speed="13.89" length="36.00" '
                               'width="12.00" shape="-2.00,', '<lane id="e0_0" index="0" '
                               'speed="13.89" length="36.00" width="12.00" shape="nan,', 1),
     "lane 'e0_0': its shape holds a coordinate that is not a number"),
    # a junction its edges name, left out of the file: read as if the network were whole
    (lambda text: text.replace('<junction id="n0" type="dead_end"', '<removed id="n0"', 1),
     "junction 'n0', which its edges name, is not in the file"),
])
def test_a_network_with_a_missing_junction_or_a_coordinate_not_a_number_is_refused(
        tmp_path, root, monkeypatch, edit, message):
    monkeypatch.setenv("ENN_TRAFFIC_CACHE", str(tmp_path / "cache"))  # no walls built before
    text = (root / "sumo_nets" / "track_narrow.net.xml").read_text()
    net = tmp_path / "edited.net.xml"
    net.write_text(edit(text))
    assert net.read_text() != text
    with warnings.catch_warnings():  # shapely's RuntimeWarning came before the error
        warnings.simplefilter("error")
        with pytest.raises(InputError, match=message) as info:
            load_track(net)
    assert "edited.net.xml" in str(info.value)


# A long token in every SUMO file the project reads (expat before 2.6 parsed a token cut by a
# block's end again at every block of 16 or 64 KiB: quadratic in its length; 48 MB took
# sumolib's network reader about 11 s, the well-formedness check about 45 s).
LONG = 48 << 20


def _long_comment(text: str, before: str) -> str:
    at = text.index(before)
    return text[:at] + "<!-- " + "x" * LONG + " -->\n" + text[at:]


def _long_attribute(text: str, before: str) -> str:
    at = text.index(before)
    return text[:at] + '<param key="k" value="' + "x" * LONG + '"/>\n' + text[at:]


def _read(kind: str, folder):
    """Write the file of ``kind`` into ``folder``; a function that reads it as a command does."""
    from sumo_road import build_road_net

    from enn_traffic.roads.lanes import lane_table
    from enn_traffic.roads.network import read_net
    from enn_traffic.roads.sumocfg import departure_span, read_sumocfg, with_includes

    net = build_road_net(folder)
    routes = folder / "r.rou.xml"
    routes.write_text('<routes><vehicle id="v" depart="0"><route edges="we me"/></vehicle>'
                      "</routes>")
    config = folder / "r.sumocfg"
    config.write_text('<configuration><input><net-file value="road.net.xml"/>'
                      '<route-files value="r.rou.xml"/></input></configuration>')
    if kind.startswith("network"):
        edit = _long_comment if "comment" in kind else _long_attribute
        net.write_text(edit(net.read_text(), "<location "))
        return lambda: read_net(net)
    if kind == "route file, a comment":
        routes.write_text(_long_comment(routes.read_text(), "<vehicle "))
        return lambda: (departure_span([routes]), with_includes([routes]),
                        lane_table(net, [routes]))
    config.write_text(_long_comment(config.read_text(), "<input>"))
    return lambda: read_sumocfg(config)


@pytest.mark.parametrize("kind", ["network, a comment", "network, an attribute",
                                  "route file, a comment", "sumocfg, a comment"])
def test_a_long_token_is_read_in_the_time_its_bytes_take(tmp_path, monkeypatch, kind):
    """Every reader of SUMO's files feeds expat large blocks (enn_traffic.roads.xmlread): a
    48 MB comment or attribute reads well within 5 s."""
    import time

    monkeypatch.setenv("ENN_TRAFFIC_MAX_INPUT_MB", "100")
    read = _read(kind, tmp_path)
    started = time.perf_counter()
    read()
    assert time.perf_counter() - started < 5.0
