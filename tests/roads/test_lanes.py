"""Choosing a start lane (``enn-traffic lanes``, ``start_lane = "auto"``): the lanes a learner
may start on, ranked by the vehicles the demand sends over them."""

import gzip

import numpy as np
import pytest
from sumo_road import road_scenario

from enn_traffic.cli import main
from enn_traffic.config import load_scenario
from enn_traffic.core.errors import InputError
from enn_traffic.roads.lanes import demand_per_edge, lane_table

# Every way a route file sends vehicles, with the vehicles each edge gets, by hand:
#   route r1 (a b) twice by vehicles: a 2, b 2
#   a flow on r1 with number 5: a 5, b 5
#   a flow from b to c, period 60 over 600 s: 10 on b and c
#   a flow on a nested route (c d), 720 per hour for 300 s: 60 on c and d
#   a trip from a to d via c: 1 on a, c, d
#   a vehicle on distribution rd (r1 with 3/4, route (d) with 1/4), eight times: a, b 6; d 2
#   a flow with probability 0.1 per s over 100 s on r1: a, b 10
#   a tram (its type's class) on r1, twice: a, b 2 trams
ROUTES = """<routes>
    <vType id="tram" vClass="tram"/>
    <route id="r1" edges="a b"/>
    <routeDistribution id="rd">
        <route id="x1" edges="a b" probability="3"/>
        <route id="x2" edges="d" probability="1"/>
    </routeDistribution>
    <vehicle id="v1" depart="0" route="r1"/>
    <vehicle id="v2" depart="1" route="r1"/>
    <flow id="f1" begin="0" end="100" number="5" route="r1"/>
    <flow id="f2" begin="0" end="600" period="60" from="b" to="c"/>
    <flow id="f3" begin="0" end="300" vehsPerHour="720"><route edges="c d"/></flow>
    <trip id="t1" depart="5" from="a" to="d" via="c"/>
    {distribution}
    <flow id="f4" begin="0" end="100" probability="0.1" route="r1"/>
    <person id="p" depart="0"><walk edges="a b"/></person>
    <flow id="trams" type="tram" begin="0" end="10" number="2" route="r1"/>
</routes>"""


def test_demand_counts_every_kind_of_route_by_hand(tmp_path):
    path = tmp_path / "demand.rou.xml.gz"
    distribution = "\n".join(f'<vehicle id="d{i}" depart="{i}" route="rd"/>' for i in range(8))
    with gzip.open(path, "wt") as handle:
        handle.write(ROUTES.format(distribution=distribution))
    demand = demand_per_edge([path])
    assert demand == pytest.approx({
        ("a", "passenger"): 2 + 5 + 1 + 6 + 10, ("b", "passenger"): 2 + 5 + 10 + 6 + 10,
        ("c", "passenger"): 10 + 60 + 1, ("d", "passenger"): 60 + 1 + 2,
        ("a", "tram"): 2, ("b", "tram"): 2})


def test_demand_routes_trips_where_they_drive(tmp_path, root, monkeypatch):
    """A trip and a flow of 4 from the ring's west side to its north side: counted on their
    end edges only, the ring's south and east sides between would get nothing; routed by
    duarouter, as SUMO routes them when they depart, every edge of the way counts 5. The
    routing leaves no temporary folder behind (it left an ``enn-routes-*`` each time)."""
    import tempfile

    temporary = tmp_path / "tmp"
    temporary.mkdir()
    monkeypatch.setattr(tempfile, "tempdir", str(temporary))
    path = tmp_path / "trips.rou.xml"
    path.write_text('<routes><trip id="t" depart="0" from="g1_0to0_0" to="g1_1to1_0"/>'
                    '<flow id="f" begin="0" end="100" number="4" from="g1_0to0_0" '
                    'to="g1_1to1_0"/></routes>')
    ends = {("g1_0to0_0", "passenger"): 5, ("g1_1to1_0", "passenger"): 5}
    assert demand_per_edge([path]) == ends
    routed = demand_per_edge([path], net_file=root / "sumo_nets" / "sumo_ring.net.xml")
    assert routed == {**ends, ("g0_0to0_1", "passenger"): 5, ("g0_1to1_1", "passenger"): 5}
    assert list(temporary.iterdir()) == []


def test_the_busiest_lane_that_does_not_lead_out_is_auto(tmp_path, road_net, capsys):
    """The road's westbound buses (60 in 600 s) drive em, then ew: of the lanes cars may use
    (we_0, ew_0, me_0; em_0 is for buses), ew_0 carries them, but it ends at the road's west
    end, the network's fringe: a learner there leaves the network within 100 m. So does
    me_0, eastwards. we_0 leads into the road: ``start_lane = "auto"`` starts there, and
    ``lanes`` lists it alone."""
    path = road_scenario(tmp_path, road_net, start='start_lane = "auto"')
    scenario = load_scenario(path)
    assert scenario.track.start_lane == "we_0"
    table = lane_table(scenario.track.net, [tmp_path / "buses.rou.xml"])
    assert list(table["lane"][:1]) == ["we_0"]
    assert dict(zip(table["lane"], table["vehicles"], strict=True)) == {
        "we_0": 0, "ew_0": 60, "em_0": 60, "me_0": 0}
    assert table["edge_vehicles"].dtype.kind == "f"
    assert dict(zip(table["lane"], table["ends_at_fringe"], strict=True)) == {
        "we_0": False, "ew_0": True, "em_0": False, "me_0": True}
    assert list(table["learner_may_start"]) == [True, False, False, False]
    assert main(["lanes", str(path), "--top", "2", "--out", str(tmp_path / "lanes.csv")]) == 0
    printed = capsys.readouterr().out
    assert "4 lanes; 3 allow passenger cars, of which 1 is 34.3 m long or longer" in printed
    assert "2 end at the network's fringe" in printed
    assert "1 bus" in printed
    assert 'start_lane = "we_0"' in printed
    assert (tmp_path / "lanes.csv").read_text().count("\n") == 5


def netconvert(folder, stem: str, nodes: str, edges: str) -> None:
    """``folder/STEM.net.xml``, built by SUMO's netconvert from the nodes and edges given."""
    import subprocess

    import sumo as sumo_wheel

    (folder / f"{stem}.nod.xml").write_text(nodes)
    (folder / f"{stem}.edg.xml").write_text(edges)
    subprocess.run([f"{sumo_wheel.SUMO_HOME}/bin/netconvert", "-n", f"{stem}.nod.xml", "-e",
                    f"{stem}.edg.xml", "-o", f"{stem}.net.xml", "--no-turnarounds", "true"],
                   cwd=folder, check=True, capture_output=True)


# A junction: "in" (two lanes, west to the middle) turns right (lane 0), runs on (lane 0) or
# turns left (lane 1), as netconvert connects it.
JUNCTION_NODES = """<nodes>
    <node id="w" x="0" y="0"/><node id="m" x="100" y="0"/><node id="e" x="200" y="0"/>
    <node id="n" x="100" y="100"/><node id="s" x="100" y="-100"/>
</nodes>"""
JUNCTION_EDGES = """<edges>
    <edge id="in" from="w" to="m" numLanes="2"/><edge id="on" from="m" to="e"/>
    <edge id="left" from="m" to="n"/><edge id="right" from="m" to="s"/>
</edges>"""
JUNCTION_ROUTES = """<routes>
    <flow id="r" begin="0" end="100" number="10"><route edges="in right"/></flow>
    <flow id="l" begin="0" end="100" number="20"><route edges="in left"/></flow>
    <flow id="o" begin="0" end="100" number="30"><route edges="in on"/></flow>
    <flow id="stop" begin="0" end="100" number="4"><route edges="in"/></flow>
</routes>"""


def test_a_lane_carries_the_vehicles_whose_route_goes_on_from_it(tmp_path):
    """Of the 64 vehicles over "in", those turning right or running on (10 + 30) may use only
    lane 0, those turning left (20) only lane 1, those that end there (4) either, one share
    each: 42 and 22, where the edge's count (64) ties them. The ranking follows."""
    netconvert(tmp_path, "j", JUNCTION_NODES, JUNCTION_EDGES)
    (tmp_path / "j.rou.xml").write_text(JUNCTION_ROUTES)
    table = lane_table(tmp_path / "j.net.xml", [tmp_path / "j.rou.xml"], exits=False)
    lanes = table.set_index("lane")
    assert lanes.loc["in_0", "vehicles"] == pytest.approx(42.0)
    assert lanes.loc["in_1", "vehicles"] == pytest.approx(22.0)
    assert lanes.loc["in_0", "edge_vehicles"] == lanes.loc["in_1", "edge_vehicles"] == 64
    assert lanes.loc["on_0", "vehicles"] == pytest.approx(30.0)
    assert list(table["lane"][:3]) == ["in_0", "on_0", "in_1"]


def test_lanes_lists_the_lanes_auto_may_choose(tmp_path, road_net, capsys):
    """``lanes`` and ``start_lane = "auto"`` apply one rule: a lane at least start_offset +
    body + 10 m long. With start_offset = 95 m, none of the road's 100 m lanes is (109.3 m):
    ``lanes`` lists none, and ``auto`` finds none."""
    path = road_scenario(tmp_path, road_net)
    path.write_text(path.read_text().replace("start_offset = 20.0", "start_offset = 95.0"))
    assert main(["lanes", str(path)]) == 0
    assert "3 allow passenger cars, of which 0 are 109.3 m long" in capsys.readouterr().out
    path.write_text(path.read_text().replace('start_lane = "we_0"', 'start_lane = "auto"'))
    with pytest.raises(InputError, match="no lane that allows passenger cars is 109.3 m"):
        load_scenario(path)


def test_a_start_lane_shorter_than_the_offset_is_an_error_naming_both(tmp_path, road_net):
    path = road_scenario(tmp_path, road_net, start='start_lane = "me_0"')
    path.write_text(path.read_text().replace("start_offset = 20.0", "start_offset = 500.0"))
    with pytest.raises(InputError, match=r"lane 'me_0' is [\d.]+ m long, shorter than "
                                         r"start_offset = 500 m") as error:
        from enn_traffic.sim.world import make_world

        make_world(load_scenario(path))
    assert "start_lane" in error.value.key


def test_auto_needs_a_lane_long_enough(tmp_path, road_net):
    path = road_scenario(tmp_path, road_net, start='start_lane = "auto"')
    path.write_text(path.read_text().replace("start_offset = 20.0", "start_offset = 95.0"))
    with pytest.raises(InputError, match="no lane that allows passenger cars is") as error:
        load_scenario(path)
    assert error.value.key == "track.start_lane"


def test_the_plots_rank_labels_never_overlap_and_rank_1_is_boxed():
    """Twelve lanes 3 m apart on a 2 km map (one street's lanes, in a city's extent): twelve
    labels, no two overlapping on the page, the first boxed in the lanes' colour."""
    import itertools

    import matplotlib.pyplot as plt

    from enn_traffic.report.plots import _rank_labels

    figure, axes = plt.subplots(figsize=(7, 7))
    axes.set_xlim(0, 2000)
    axes.set_ylim(0, 2000)
    anchors = [np.array([1000.0, 1000.0 + 3.0 * k]) for k in range(12)]
    _rank_labels(figure, axes, anchors)
    figure.canvas.draw()
    renderer = figure.canvas.get_renderer()
    labels = {text.get_text(): text for text in axes.texts}
    assert sorted(labels, key=int) == [str(rank) for rank in range(1, 13)]
    boxes = [text.get_bbox_patch().get_window_extent(renderer) for text in labels.values()]
    assert not any(a.overlaps(b) for a, b in itertools.combinations(boxes, 2))
    assert labels["1"].get_bbox_patch().get_facecolor() != labels["2"].get_bbox_patch(
        ).get_facecolor()
    plt.close(figure)


NARROW_NODES = """<nodes>
    <node id="w" x="0" y="0"/><node id="m" x="100" y="0"/><node id="e" x="200" y="0"/>
    <node id="f" x="300" y="0"/>
</nodes>"""
# "a" is 1.5 m wide, narrower than the 1.8 m car; "b" and "c" are 3.5 m wide.
NARROW_EDGES = """<edges>
    <edge id="a" from="w" to="m" width="1.5"/><edge id="b" from="m" to="e" width="3.5"/>
    <edge id="c" from="e" to="f" width="3.5"/>
</edges>"""
NARROW_ROUTES = """<routes>
    <flow id="busy" begin="0" end="100" number="80"><route edges="a"/></flow>
    <flow id="quiet" begin="0" end="100" number="20"><route edges="b c"/></flow>
</routes>"""
NARROW_CONFIG = """<configuration><input><net-file value="n.net.xml"/>
    <route-files value="n.rou.xml"/></input></configuration>"""


def test_a_start_that_puts_the_body_over_the_roads_edge_is_refused_and_auto_skips_it(
        tmp_path, capsys):
    """Lane a_0 carries the most vehicles (80) and passes every other check, but it is 1.5 m
    wide: a 1.8 m car there reaches over the road's edge, and every life would end at a wall at
    step 0. Named as the start, it is refused, naming the key; ``auto`` takes b_0 (20), and
    ``lanes`` leaves a_0 out and says so."""
    netconvert(tmp_path, "n", NARROW_NODES, NARROW_EDGES)
    (tmp_path / "n.rou.xml").write_text(NARROW_ROUTES)
    (tmp_path / "n.sumocfg").write_text(NARROW_CONFIG)
    path = tmp_path / "s.toml"
    scenario = ('name = "narrow"\n[track]\nstart_lane = "{lane}"\n[vehicle]\nwidth = 1.8\n'
                '[traffic]\n'
                'strategy = "sumo"\nsumocfg = "n.sumocfg"\nwarmup_s = 0\n')
    path.write_text(scenario.format(lane="a_0"))
    from enn_traffic.sim.world import make_world

    with pytest.raises(InputError, match="reaches over the edge") as refused:
        make_world(load_scenario(path))
    assert refused.value.key == "track.start_lane"
    path.write_text(scenario.format(lane="auto"))
    assert load_scenario(path).track.start_lane == "b_0"
    capsys.readouterr()
    assert main(["lanes", str(path)]) == 0
    printed = capsys.readouterr().out
    assert "1 busier lane left out" in printed and 'start_lane = "b_0"' in printed
    assert "a_0" not in printed.split("edge_vehicles")[-1]
