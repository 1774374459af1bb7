"""``enn-traffic lanes``: the lanes a learner may start on, ranked by the traffic demand."""

from __future__ import annotations

from pathlib import Path

from enn_traffic.cli.args import EPILOG, nonempty_path, positive


def add_parser(commands) -> None:
    """The command's arguments."""
    command = commands.add_parser(
        "lanes", help="the lanes a learner may start on, ranked by the traffic demand",
        epilog=EPILOG, description="List the lanes of a scenario's network that allow passenger "
        "cars (where a learner may start: [track] start_lane), ranked by the vehicles its route "
        "files send over them (a lane's share of its edge's: the vehicles whose route goes on "
        "from that lane), with their lengths and allowed vehicle classes; and count the "
        "lanes cars may not use.")
    command.add_argument("source", type=nonempty_path, metavar="SCENARIO.toml|FILE.sumocfg",
                         help="a scenario, or a SUMO configuration (its network and routes)")
    command.add_argument("--top", metavar="N", type=positive, default=20,
                         help="lanes listed, and numbered in --plot (default 20)")
    command.add_argument("--out", type=nonempty_path, metavar="FILE.csv", help="write every lane")
    command.add_argument("--plot", type=nonempty_path, metavar="FILE.png",
                         help="draw the road surface for cars against every lane as road, with "
                              "the top start lanes numbered")


def run(args) -> int:
    from enn_traffic.config import sumo_sources
    from enn_traffic.config.shipped import scenario_path
    from enn_traffic.core.io import check_output_file, write_csv
    from enn_traffic.roads.lanes import lane_table
    from enn_traffic.roads.network import ANYWHERE_AHEAD_M

    if args.out:
        check_output_file(args.out, suffixes=(".csv",))
    if args.plot:
        check_output_file(args.plot, "--plot", suffixes=(".png", ".svg", ".pdf"))
    net, routes, additional, start = sumo_sources(scenario_path(args.source))
    shortest = start.shortest
    # ties of demand are ranked by length, then by the lane's name
    table = lane_table(net, routes, additional, shortest)
    learner = table[table["learner_may_start"]]
    cars = table["allows_cars"]
    source = scenario_path(args.source)
    rule = (f"start_offset + body + {ANYWHERE_AHEAD_M:g} m ahead, as start_lane = \"auto\" "
            "asks" + ("; a .sumocfg is read with start_offset = 10 m and a 4.3 m body: run "
                      "lanes on your scenario file for its own" if source.suffix == ".sumocfg"
                      else ""))
    fringe = int((cars & table["ends_at_fringe"]).sum())
    print(f"{net.name}: {len(table):,} lanes; {int(cars.sum()):,} allow passenger cars, of "
          f"which {len(learner):,} {'is' if len(learner) == 1 else 'are'} {shortest:g} m long "
          f"or longer and do not end at the network's fringe (a learner may start there: "
          f"{rule}); {fringe:,} end at the network's fringe (an exit, or a dead end); "
          f"{int((~cars).sum()):,} do not allow cars")
    if (~cars).any():
        kinds = table[~cars]["allowed"].replace("", "no vehicle").value_counts()
        print("  not for cars: " + ", ".join(f"{count:,} {kind}" for kind, count
                                               in kinds.head(6).items()))
    demand = "routes: " + ", ".join(p.name for p in routes) if routes else "no route files"
    print(f"the learner's lanes by the vehicles the demand sends over them, trips routed as "
          f"SUMO routes them ({demand}); vehicles: the lane's share of its edge's "
          f"edge_vehicles, those whose route goes on from that lane (docs/sumo.md):")
    columns = ["lane", "edge", "vehicles", "edge_vehicles", "length_m", "speed_limit_kmh",
               "allowed"]
    learner, skipped = _clear_head(learner, start.clear, args.top)
    ranked = learner[columns].assign(rank=range(1, len(learner) + 1))
    print(ranked.head(args.top)[["rank", *columns]].to_string(index=False))
    if skipped:
        print(f"({skipped:,} busier {'lane' if skipped == 1 else 'lanes'} left out: the body "
              "at start_offset would reach over the road's edge there, a bend or a narrow "
              "lane; auto skips them too)")
    starts = _scenario_starts(source, table)
    if starts is not None:
        key, chosen = starts
        chosen = chosen.merge(ranked[["lane", "rank"]], on="lane", how="left")
        chosen["rank"] = chosen["rank"].map(lambda r: "-" if r != r else f"{int(r)}")
        print(f"\nthe scenario's own start, {key} (rank among the learner's lanes; - where "
              "auto would not start):")
        print(chosen[["rank", *columns, "ends_at_fringe"]].to_string(index=False))
    elif len(learner):
        print(f'\nstart there: [track] start_lane = "{learner.iloc[0]["lane"]}" '
              '(or start_lane = "auto")')
    if args.out:
        write_csv(args.out, table)
        print(f"written {args.out}")
    if args.plot:
        _plot_lanes(net, learner.head(args.top), args.plot)
        print(f"written {args.plot}")
    return 0


def _clear_head(learner, clear, top: int):
    """The learner's lanes with those whose start would put the body over the road's edge
    (``clear`` false) left out, as ``start_lane = "auto"`` leaves them, tested in rank order
    until ``top`` pass (the rest are not tested); and how many were left out."""
    import pandas as pd

    keep, left_out, passed = [], 0, 0
    for lane in learner["lane"]:
        if passed >= top:
            keep.append(True)
            continue
        fits = clear(str(lane))
        keep.append(fits)
        passed += fits
        left_out += not fits
    return learner.loc[pd.Series(keep, index=learner.index, dtype=bool)], left_out


def _scenario_starts(source, table):
    """A scenario file's own start lanes, when it names them (``start_lane`` or
    ``start_edge``, not ``auto``): (its key as written, their rows of ``table``)."""
    import tomllib

    from enn_traffic.config import load_scenario

    if source.suffix == ".sumocfg":
        return None
    written = tomllib.loads(source.read_text(encoding="utf-8")).get("track", {})
    if not isinstance(written, dict) or written.get("start_lane") == "auto":
        return None
    track = load_scenario(source).track
    for key in ("start_lane", "start_edge"):
        value = getattr(track, key)
        if value is None or value == "auto":
            continue
        names = [value] if isinstance(value, str) else list(value)
        column = "lane" if key == "start_lane" else "edge"
        rows = table[table[column].isin(names)]
        return f"{key} = {names if len(names) > 1 else names[0]!r}", rows
    return None


def _plot_lanes(net: Path, top, out: Path) -> None:
    """The surfaces ``passenger`` and ``all`` of ``net``, the ``top`` lanes on the first."""
    import numpy as np

    from enn_traffic.report.plots import road_surfaces
    from enn_traffic.roads import load_track
    from enn_traffic.roads.network import read_net

    tracks = {surface: load_track(net, exits=True, surface=surface)
              for surface in ("all", "passenger")}
    network = read_net(net)
    shapes = [(lane, np.asarray(network.getLane(lane).getShape())) for lane in top["lane"]]
    road_surfaces({'surface = "all": every lane is road': (tracks["all"].area,
                                                           tracks["all"].walls),
                   'surface = "passenger" (default): the road for cars':
                       (tracks["passenger"].area, tracks["passenger"].walls)},
                  shapes, out, net.name)
