"""Write the plain-XML sources of the shipped tracks and build them with netconvert.

Usage (from the repository root; netconvert comes with the ``eclipse-sumo`` wheel):

    python sumo_nets/build.py            # rewrite *.nod.xml/*.edg.xml and rebuild every *.net.xml
    python sumo_nets/build.py street     # build scenarios/street/street.net.xml.gz only

Each track is a chain of nodes on the corridor centreline joined by one-lane edges whose lane
width is the corridor width (``spreadType="center"`` keeps the lane centred on the node line).
Corner nodes of the authors' tracks carry a square ``shape`` so that the union of lane and
junction shapes has the square corners of the reference polyline
(docs/design.md, "The authors' code" 1); other tracks keep netconvert's own rounded
junction shapes. ``track_grid`` is a small town grid with three 5 m lanes each way (30 m roads).
"""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent

# Centreline of the authors' 12 m navigation corridor (docs/design.md, "The authors' code" 1): the
# medial line of their 57-segment polyline, from the start cap (-8..4, -20) to the far cap at B.
NARROW_CENTRELINE = [
    (-2, -20), (-2, 16), (28, 16), (28, 34), (-52, 34), (-52, 76), (-22, 76), (-22, 144),
    (-40, 144), (-40, 104), (-82, 104), (-82, 196), (-2, 196), (-2, 214), (-190, 214),
    (-190, 196), (-150, 196), (-150, 154), (-230, 154), (-230, 136), (-190, 136), (-190, 76),
    (-172, 76), (-172, 136), (-130, 136), (-130, 44), (-210, 44), (-210, -30),
]
# The wide track is the same course scaled by 2.5: a 30 m corridor, the width the authors name
# for their wide map (README of their code, "30 m instead of 12 m"), with 15 m wall blocks
# between neighbouring legs. At 24 m (scale 2) no seed learned the 180-degree turn at B within
# 50 generations; at 30 m most do.
WIDE_SCALE = 2.5

TRACKS = {
    "track_narrow": dict(points=NARROW_CENTRELINE, width=12.0, square_corners=True),
    "track_wide": dict(
        points=[(x * WIDE_SCALE, y * WIDE_SCALE) for x, y in NARROW_CENTRELINE],
        width=12.0 * WIDE_SCALE,
        square_corners=True,
    ),
    # 100 m x 100 m free area: one 100 m-wide lane from x=0 to x=100 along y=50.
    "arena": dict(points=[(0, 50), (100, 50)], width=100.0, square_corners=False),
    # Tracks for generalisation, in the wide track's 30 m width class but of other shapes.
    # A closed rectangular ring road with netconvert's rounded corners.
    "track_loop": dict(
        points=[(0, 0), (200, 0), (200, 120), (0, 120)], width=30.0, square_corners=False,
        closed=True,
    ),
    # A dead-ended course with 45-degree legs.
    "track_zigzag": dict(
        points=[(0, -10), (0, 60), (50, 110), (50, 190), (0, 240), (-60, 240), (-110, 290),
                (-110, 370)],
        width=30.0, square_corners=False,
    ),
}

# Tracks for training across tracks (scenarios/navigation_mixed.toml) and the unseen ones it is
# measured on (``unseen_*``; never trained on). Widths 12–30 m; bends from 30° to 135°; loops,
# junctions and dead ends, where the vehicle must turn round within the track's width.
MIXED_TRACKS = {
    # 12 m, dead-ended both ends; bends of 30°, 60°, 90°, 120°, alternately left and right.
    "train_bends12": dict(
        points=[(0, -10), (0, 60), (-30, 112), (-30, 172), (60, 172), (60, 232), (8, 262),
                (8, 330)],
        width=12.0),
    # 18 m closed loop: corners from 45° to 110°.
    "train_loop18": dict(
        points=[(0, 0), (160, 0), (220, 60), (180, 160), (60, 120), (0, 180), (-60, 90)],
        width=18.0, closed=True),
    # 24 m dead-ended course with 60° bends.
    "train_zigzag24": dict(
        points=[(0, -10), (0, 70), (70, 110), (70, 190), (0, 230), (0, 310)], width=24.0),
    # 30 m U-turn course, dead-ended both ends: two 90° bends close together.
    "train_hairpin30": dict(
        points=[(0, -10), (0, 150), (80, 150), (80, -10)], width=30.0),
    # Unseen: a 14 m dead-ended zigzag with 45° bends (a dead end to turn round in 14 m).
    "unseen_zigzag14": dict(
        points=[(0, -10), (0, 60), (40, 100), (40, 170), (0, 210), (-50, 210), (-90, 250),
                (-90, 320)],
        width=14.0),
    # Unseen: a 16 m loop with two sharp and two gentle corners.
    "unseen_loop16": dict(
        points=[(0, 0), (180, 0), (120, 100), (180, 200), (0, 200), (-40, 100)], width=16.0,
        closed=True),
}
# Junction networks of one lane per road (its width the road's), dead ends at their arms' ends.
JUNCTION_TRACKS = {
    # 16 m roads: a crossroads and a T junction, five dead-ended arms.
    "train_junctions16": dict(
        nodes={"c": (0, 0), "w": (-110, 0), "n": (0, 110), "s": (0, -110), "t": (110, 0),
               "tn": (110, 80), "ts": (110, -80)},
        roads=[("w", "c"), ("c", "n"), ("c", "s"), ("c", "t"), ("t", "tn"), ("t", "ts")],
        width=16.0),
    # Unseen, 20 m roads: a loop with a crossroads in it and two dead-ended spurs.
    "unseen_junctions20": dict(
        nodes={"a": (0, 0), "b": (160, 0), "c": (160, 160), "d": (0, 160), "m": (80, 80),
               "e": (-90, 0), "f": (160, 250)},
        roads=[("a", "b"), ("b", "c"), ("c", "d"), ("d", "a"), ("a", "m"), ("m", "c"),
               ("b", "m"), ("m", "d"), ("e", "a"), ("c", "f")],
        width=20.0),
}
# The test tracks of training across tracks (``test_*``): built after the unseen tracks had
# been read and the design changed (docs/results.md, "Generalisation across tracks"), and read
# once, by the final configuration. Widths 12-30 m, bends of 45-120 degrees, square corners
# like the authors' tracks, a loop, junctions, and dead ends to turn round in 12-13 m.
TEST_TRACKS = {
    # 13 m dead-ended course, bends of 45, 80 and 60 degrees.
    "test_bends13": dict(
        points=[(0, -10), (0, 50), (40, 90), (40, 150), (-20, 190), (-20, 260)], width=13.0),
    # 16 m dead-ended course with the authors' square corners, three 90-degree turns.
    "test_square16": dict(
        points=[(0, -10), (0, 60), (60, 60), (60, 130), (-30, 130), (-30, 200)], width=16.0,
        square_corners=True),
    # 20 m dead-ended U of two 90-degree bends, then a 90-degree bend out of it.
    "test_snake20": dict(
        points=[(0, -10), (0, 80), (90, 80), (90, 170), (0, 170), (0, 250)], width=20.0),
    # 26 m closed loop, corners of 60-120 degrees.
    "test_loop26": dict(
        points=[(0, 0), (200, 0), (250, 90), (150, 180), (20, 140)], width=26.0, closed=True),
    # 30 m dead-ended course with bends of 30-70 degrees.
    "test_zigzag30": dict(
        points=[(0, -10), (0, 80), (80, 140), (80, 240), (-20, 300)], width=30.0),
}
TEST_JUNCTIONS = {
    # 12 m roads: a crossroads and a T junction, dead ends at 12 m.
    "test_junctions12": dict(
        nodes={"c": (0, 0), "s": (0, -100), "w": (-90, 0), "n": (0, 90), "e": (100, 0),
               "en": (100, 70), "ee": (180, 0)},
        roads=[("s", "c"), ("c", "w"), ("c", "n"), ("c", "e"), ("e", "en"), ("e", "ee")],
        width=12.0),
    # 24 m roads: a triangle loop with two dead-ended spurs.
    "test_junctions24": dict(
        nodes={"a": (0, 0), "b": (200, 0), "c": (100, 170), "d": (-100, 0), "f": (100, 280)},
        roads=[("a", "b"), ("b", "c"), ("c", "a"), ("d", "a"), ("c", "f")],
        width=24.0),
}


def _fmt(v: float) -> str:
    return f"{v:g}"


def corridor_xml(points, width, square_corners, closed=False) -> tuple[str, str]:
    """Plain node and edge XML for a one-lane corridor along ``points``."""
    half = width / 2
    n = len(points)
    nodes = ["<nodes>"]
    for i, (x, y) in enumerate(points):
        end = not closed and i in (0, n - 1)
        attrs = f'id="n{i}" x="{_fmt(x)}" y="{_fmt(y)}"'
        if end:
            nodes.append(f'    <node {attrs} type="dead_end"/>')
        elif square_corners:
            shape = " ".join(
                f"{_fmt(x + dx)},{_fmt(y + dy)}"
                for dx, dy in ((-half, -half), (half, -half), (half, half), (-half, half))
            )
            nodes.append(f'    <node {attrs} type="priority" shape="{shape}"/>')
        else:
            nodes.append(f'    <node {attrs} type="priority"/>')
    nodes.append("</nodes>")
    edges = ["<edges>"]
    pairs = [(i, i + 1) for i in range(n - 1)] + ([(n - 1, 0)] if closed else [])
    for a, b in pairs:
        edges.append(
            f'    <edge id="e{a}" from="n{a}" to="n{b}" numLanes="1" width="{_fmt(width)}"'
            ' speed="13.89" spreadType="center"/>'
        )
    edges.append("</edges>")
    return "\n".join(nodes) + "\n", "\n".join(edges) + "\n"


def junctions_xml(nodes: dict[str, tuple[float, float]], roads: list[tuple[str, str]],
                  width: float) -> tuple[str, str]:
    """Plain XML of a network of one-lane roads ``width`` wide between named ``nodes``: a node
    on one road is a dead end, the others junctions with netconvert's own shapes."""
    degree = {name: sum(name in road for road in roads) for name in nodes}
    lines = ["<nodes>"]
    for name, (x, y) in nodes.items():
        kind = "dead_end" if degree[name] == 1 else "priority"
        lines.append(f'    <node id="{name}" x="{_fmt(x)}" y="{_fmt(y)}" type="{kind}"/>')
    lines.append("</nodes>")
    edges = ["<edges>"]
    for a, b in roads:
        edges.append(f'    <edge id="{a}{b}" from="{a}" to="{b}" numLanes="1" '
                     f'width="{_fmt(width)}" speed="13.89" spreadType="center"/>')
    edges.append("</edges>")
    return "\n".join(lines) + "\n", "\n".join(edges) + "\n"


def grid_xml(blocks: int = 3, block_length: float = 120.0, lanes: int = 3,
             lane_width: float = 5.0, junction: str = "priority") -> tuple[str, str]:
    """Plain XML of a town grid: (blocks+1)^2 junctions of type ``junction``, two-way roads,
    ``lanes`` lanes each way."""
    nodes = ["<nodes>"]
    for i in range(blocks + 1):
        for j in range(blocks + 1):
            nodes.append(
                f'    <node id="g{i}_{j}" x="{_fmt(i * block_length)}" y="{_fmt(j * block_length)}"'
                f' type="{junction}"/>'
            )
    nodes.append("</nodes>")
    edges = ["<edges>"]
    for i in range(blocks + 1):
        for j in range(blocks + 1):
            for di, dj in ((1, 0), (0, 1)):
                a, b = (i, j), (i + di, j + dj)
                if b[0] > blocks or b[1] > blocks:
                    continue
                for src, dst in ((a, b), (b, a)):
                    edges.append(
                        f'    <edge id="g{src[0]}_{src[1]}to{dst[0]}_{dst[1]}"'
                        f' from="g{src[0]}_{src[1]}" to="g{dst[0]}_{dst[1]}" numLanes="{lanes}"'
                        f' width="{_fmt(lane_width)}" speed="13.89"/>'
                    )
    edges.append("</edges>")
    return "\n".join(nodes) + "\n", "\n".join(edges) + "\n"


def netconvert_command(name: str) -> list[str]:
    """The netconvert call that builds ``name.net.xml`` from its plain XML. Networks that SUMO
    traffic drives on keep their internal (junction) lanes, so that vehicles drive through
    junctions instead of jumping across them."""
    return [
        _netconvert(),
        "--node-files", f"{name}.nod.xml",
        "--edge-files", f"{name}.edg.xml",
        "--output-file", f"{name}.net.xml",
        "--offset.disable-normalization",  # keep the authors' coordinates
        "--no-turnarounds",
        *([] if name in TRAFFIC_NETS else ["--no-internal-links"]),
    ]


# Networks for SUMO traffic (scenarios/sumo_strategy*.toml): a square two-way ring road and a
# two-block grid whose centre is an unsignalised crossroads where drivers yield to the right.
# Three 5 m lanes each way (30 m roads), the width class the learner handles (track_wide).
TRAFFIC_NETS = {
    "sumo_ring": dict(blocks=1, block_length=160.0),
    "sumo_grid": dict(blocks=2, block_length=120.0, junction="right_before_left"),
}


def _netconvert() -> str:
    exe = shutil.which("netconvert")
    if exe is None:
        import sumo  # the eclipse-sumo wheel

        exe = str(Path(sumo.SUMO_HOME) / "bin" / "netconvert")
    return exe


def build_street() -> int:
    """The test street of scenarios/street/ (street.nod.xml, street.edg.xml: written by hand),
    gzipped as publishers ship networks, with walking areas and crossings at its junction."""
    result = subprocess.run([
        _netconvert(), "--node-files", "street.nod.xml", "--edge-files", "street.edg.xml",
        "--output-file", str(HERE.parent / "scenarios" / "street" / "street.net.xml.gz"),
        "--offset.disable-normalization", "--no-turnarounds", "--walkingareas", "true",
        "--crossings.guess", "true",
    ], cwd=HERE, capture_output=True, text=True)  # fmt: skip
    if result.returncode != 0:
        print(result.stdout, result.stderr, file=sys.stderr)
    else:
        print("built scenarios/street/street.net.xml.gz")
    return result.returncode


def main() -> int:
    if sys.argv[1:] == ["street"]:
        return build_street()
    sources = {name: corridor_xml(**spec) for name, spec in TRACKS.items()}
    sources.update({name: corridor_xml(square_corners=False, **spec)
                    for name, spec in MIXED_TRACKS.items()})
    sources.update({name: corridor_xml(**{"square_corners": False, **spec})
                    for name, spec in TEST_TRACKS.items()})
    sources.update({name: junctions_xml(**spec)
                    for name, spec in {**JUNCTION_TRACKS, **TEST_JUNCTIONS}.items()})
    sources["track_grid"] = grid_xml()
    sources.update({name: grid_xml(**spec) for name, spec in TRAFFIC_NETS.items()})
    for name, (nod, edg) in sources.items():
        (HERE / f"{name}.nod.xml").write_text(nod)
        (HERE / f"{name}.edg.xml").write_text(edg)
        result = subprocess.run(netconvert_command(name), cwd=HERE, capture_output=True, text=True)
        if result.returncode != 0:
            print(result.stdout, result.stderr, file=sys.stderr)
            return result.returncode
        print(f"built {name}.net.xml")
    return build_street()


if __name__ == "__main__":
    sys.exit(main())
