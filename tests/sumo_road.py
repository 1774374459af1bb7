"""A straight two-way road with buses, as a user's own SUMO scenario: its network, route file,
``.sumocfg`` and scenario file, written into a test's folder."""

import subprocess

import numpy as np

# A straight two-way road from x = 0 to x = 200 (4 m lanes, centre lines at y = -2 eastbound
# and y = +2 westbound), joined at x = 100; its ends are the network's fringe. The westbound
# half from x = 200 to 100 is for buses only.
NODES = """<nodes>
    <node id="w" x="0" y="0" type="priority"/>
    <node id="m" x="100" y="0" type="priority"/>
    <node id="e" x="200" y="0" type="priority"/>
</nodes>"""
EDGES = """<edges>
    <edge id="we" from="w" to="m" numLanes="1" speed="13.9" width="4"/>
    <edge id="ew" from="m" to="w" numLanes="1" speed="13.9" width="4"/>
    <edge id="me" from="m" to="e" numLanes="1" speed="13.9" width="4"/>
    <edge id="em" from="e" to="m" numLanes="1" speed="13.9" width="4" allow="bus"/>
</edges>"""
# One westbound bus per 10 s from ``begin`` on: traffic beside the learner's lane, never in it.
BUSES = """<routes>
    <vType id="bus" vClass="bus" length="12" width="2.5" sigma="0"/>
    <flow id="bus" type="bus" begin="{begin}" end="{end}" period="10" departSpeed="max">
        <route edges="em ew"/>
    </flow>
</routes>"""
CONFIG = """<configuration>
    <input>
        <net-file value="road.net.xml"/>
        <route-files value="buses.rou.xml"/>
    </input>
    <time><begin value="{begin}"/>{end}</time>
</configuration>"""
SCENARIO = """name = "road"
[track]
{start}
start_offset = 20.0
{fringe}
[episode]
max_steps = 400
[traffic]
strategy = "sumo"
sumocfg = "road.sumocfg"
warmup_s = {warmup}
episodes = 2
{extra}
"""


def build_road_net(folder):
    """The road's network, built by netconvert into ``folder``."""
    (folder / "road.nod.xml").write_text(NODES)
    (folder / "road.edg.xml").write_text(EDGES)
    import sumo as sumo_wheel  # netconvert of the eclipse-sumo wheel

    netconvert = f"{sumo_wheel.SUMO_HOME}/bin/netconvert"
    subprocess.run([netconvert, "-n", "road.nod.xml", "-e", "road.edg.xml", "-o", "road.net.xml",
                    "--no-turnarounds", "true"], cwd=folder, check=True, capture_output=True)
    return folder / "road.net.xml"


def road_scenario(tmp_path, road_net, begin=1000.0, departs=1000.0, end="", warmup=10.0,
                  start='start_lane = "we_0"', fringe="", extra=""):
    """A scenario on the straight road whose ``.sumocfg`` (beside it) begins at ``begin`` and
    whose buses depart from ``departs`` on."""
    (tmp_path / "road.net.xml").write_bytes(road_net.read_bytes())
    (tmp_path / "buses.rou.xml").write_text(BUSES.format(begin=departs, end=departs + 600))
    end_tag = f'<end value="{end}"/>' if end != "" else ""
    (tmp_path / "road.sumocfg").write_text(CONFIG.format(begin=begin, end=end_tag))
    path = tmp_path / "scenario.toml"
    path.write_text(SCENARIO.format(start=start, fringe=fringe, warmup=warmup, extra=extra))
    return path


def straight(world) -> np.ndarray:
    """A chromosome that steers straight ahead: all genes 0, so both outputs are equal."""
    return np.zeros((1, world.spec.chromosome_length))
