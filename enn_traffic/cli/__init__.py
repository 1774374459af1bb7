"""The ``enn-traffic`` command line (docs/design.md, "Command line").

Bad input ends with one message naming the file and key, and exit status 2; never a traceback.
"""

from __future__ import annotations

import argparse
import contextlib
import errno
import signal
import sys
import threading
import time
from pathlib import Path

from enn_traffic import __version__
from enn_traffic.core import interrupts as stopping
from enn_traffic.core.errors import InputError

EPILOG = "Scenario files are described in docs/scenarios.md."


def _int_in(minimum: int, maximum: int | None = None):
    """An argparse type: an integer from ``minimum`` to ``maximum`` (no upper bound: None)."""

    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            value = None
        if value is None or value < minimum or (maximum is not None and value > maximum):
            bounds = f">= {minimum}" if maximum is None else f"from {minimum} to {maximum:,}"
            raise argparse.ArgumentTypeError(f"expected an integer {bounds}, got {text!r}")
        return value

    return parse


def _path(text: str) -> Path:
    """An argparse type: a path, never empty (an empty one would be the current folder)."""
    if not text.strip():
        raise argparse.ArgumentTypeError("expected a path, got an empty one")
    return Path(text)


_positive, _non_negative = _int_in(1), _int_in(0)
_seed = _int_in(0, 2**63 - 1)  # scenario.MAX_SEED: seeds are mixed into 64-bit keys
# The schema's own bounds, written again so that --help need not import it (a test compares):
# ga.generations and ga.population_size, episode.max_steps, traffic.episodes
_count, _steps, _episodes = _int_in(1, 100_000), _int_in(1, 10_000_000), _int_in(1, 1000)


def _run_folder_options(command: argparse.ArgumentParser, resume: str, force: str) -> None:
    """--resume or --force, --quiet and --verbose: a command that writes a run folder."""
    again = command.add_mutually_exclusive_group()
    again.add_argument("--resume", action="store_true", help=resume)
    again.add_argument("--force", action="store_true", help=force)
    command.add_argument("--quiet", action="store_true", help="no progress bar or messages")
    command.add_argument("--verbose", action="store_true",
                         help="show SUMO's console instead of logging it to OUT/sumo/sumo.log")


class _Parser(argparse.ArgumentParser):
    """argparse with a bad command line as every other error: one line, ``enn-traffic:
    error: ...`` (the command named in it), exit status 2; ``--help`` shows the usage."""

    def error(self, message: str):
        command = self.prog.removeprefix("enn-traffic").strip()
        print(f"enn-traffic: error: {command + ': ' if command else ''}{message} "
              f"(see {self.prog} --help)", file=sys.stderr)
        raise SystemExit(2)


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(
        prog="enn-traffic",
        description="Evolve neural-network driving controllers in SUMO traffic "
        "(Eraqi et al., 2016).",
        epilog=EPILOG,
    )
    parser.add_argument("--version", action="version", version=f"enn-traffic {__version__}")
    commands = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

    run = commands.add_parser("run", help="evolve a controller on a scenario", epilog=EPILOG,
                              description="Evolve a controller; writes scenario.toml, "
                              "generations.csv, best.npz, learning_curve.png, outputs.npz and "
                              "a checkpoint.")
    run.add_argument("scenario", type=_path, metavar="SCENARIO.toml",
                     help="a scenario file, or a shipped scenario's name (navigation_narrow)")
    run.add_argument("--out", type=_path, help="run folder (default: results/<scenario name>)")
    run.add_argument("--seed", type=_seed, help="override the scenario's seed")
    run.add_argument("--generations", type=_count, help="override ga.generations")
    run.add_argument("--population", type=_count, help="override ga.population_size")
    run.add_argument("--executor", choices=["local", "process", "ray"], default="local",
                     help="where fitness is evaluated (default: local, in-process)")
    run.add_argument("--address", help="Ray cluster address (with --executor ray)")
    _run_folder_options(run, "continue the run in the folder from its checkpoint",
                        "start over even if the folder holds another run")

    evaluate = commands.add_parser(
        "evaluate", help="run saved controllers on scenarios", epilog=EPILOG,
        description="Run each controller on each scenario's held-out traffic situations. One "
        "pair prints its lifetimes; several print the controller x scenario matrix of mean "
        "fitness. --out FILE.csv writes every situation (tidy) and, for several pairs, "
        "FILE_matrix.csv and FILE_matrix.png (heat map).")
    evaluate.add_argument("paths", type=_path, nargs="+", metavar="FILE",
                          help="controllers (.npz) and scenarios (.toml): one or more of each, "
                               "in any order")
    evaluate.add_argument("--episodes", type=_episodes, default=1,
                          help="traffic situations per pair (default 1)")
    evaluate.add_argument("--out", type=_path, metavar="FILE.csv", help="write the lifetimes")
    evaluate.add_argument("--mode", choices=["replay", "closed-loop"],
                          help="SUMO traffic: replayed, or reacting to the controller "
                               "(default: the scenario's traffic.mode)")
    evaluate.add_argument("--traffic-seed", type=_seed, metavar="N",
                          help="traffic seed (default: each scenario's traffic.seed); another "
                          "seed gives traffic situations that no training or choice drew "
                          "(lane keeping has no traffic: it ignores this)")
    evaluate.add_argument("--executor", choices=["local", "process", "ray"], default="local",
                          help="where the pairs run (default: local, one after another)")
    evaluate.add_argument("--address", help="Ray cluster address (with --executor ray)")
    evaluate.add_argument("--quiet", action="store_true", help="no progress bar or messages")
    evaluate.add_argument("--verbose", action="store_true",
                          help="show SUMO's console instead of logging it (to FILE_sumo/ "
                               "beside --out)")

    render = commands.add_parser("render", help="draw a controller's path (PNG) or animate it "
                                 "(GIF)", epilog=EPILOG)
    render.add_argument("controller", type=_path, metavar="CONTROLLER.npz")
    render.add_argument("scenario", type=_path, metavar="SCENARIO.toml")
    render.add_argument("--out", type=_path, required=True, metavar="FILE.png|FILE.gif")
    render.add_argument("--max-steps", type=_steps, default=5000,
                        help="draw at most this many steps (default 5000)")
    render.add_argument("--quiet", action="store_true", help="no progress bar or messages")
    render.add_argument("--verbose", action="store_true",
                        help="show SUMO's console instead of logging it (to FILE_sumo/ beside "
                             "--out)")

    reproduce = commands.add_parser("reproduce", help="run the paper's experiments",
                                    epilog=EPILOG)
    reproduce.add_argument("--out", type=_path, default=Path("results/paper"))
    reproduce.add_argument("--quick", action="store_true",
                           help="small populations and few generations (minutes)")
    reproduce.add_argument("--only", help="comma-separated experiment names (default: all)")
    reproduce.add_argument("--executor", choices=["local", "ray"], default="local",
                           help="where independent whole runs go: one after another here "
                                "(default) or side by side as Ray tasks")
    reproduce.add_argument("--address", help="Ray cluster address (with --executor ray; "
                                             "default: start a local Ray)")
    reproduce.add_argument("--quiet", action="store_true", help="no progress bars or messages")

    crowd = commands.add_parser(
        "crowd", help="every vehicle learning at once in a SUMO scenario (Tables 3-4)",
        epilog=EPILOG, description="Tables 3-4 of the paper on your SUMO scenario: the "
        "scenario's GA evolves a winner among SUMO's traffic (OUT/individual/, as run writes "
        "it), then traffic.learners vehicles drive at once in one SUMO, closed loop, in each "
        "of crowd.situations test situations: initial drivers, the winner for all, and every "
        "vehicle evolving on. Writes OUT/table3.csv, table4.csv, table4_learners.csv, "
        "table4_learning.csv and .png, table4_learning_ends.csv, crowd_situations.csv, "
        "table4_validation_learners.csv, controllers/ and crowd.gif (docs/sumo.md, 'Every car "
        "learning in your city').")
    crowd.add_argument("scenario", type=_path, metavar="SCENARIO.toml",
                       help="a SUMO scenario file, or a shipped one's name (sumo_strategy1)")
    crowd.add_argument("--out", type=_path,
                       help="folder (default: results/<scenario name>_crowd)")
    crowd.add_argument("--learners", type=_int_in(1, 1000),
                       help="override traffic.learners (vehicles learning in one SUMO)")
    crowd.add_argument("--quick", action="store_true",
                       help="minutes: 2 generations of the GA, 20 s of learning in 10 s "
                            "windows, 2 situations, 1 validation situation (too short to "
                            "breed: a check that it runs)")
    crowd.add_argument("--executor", choices=["local", "process", "ray"], default="local",
                       help="where the GA's fitness is evaluated and, with ray, the "
                            "situations run side by side (default: local)")
    crowd.add_argument("--address", help="Ray cluster address (with --executor ray)")
    _run_folder_options(crowd, "continue the crowd run in the folder",
                        "start over, even in a folder of other files (those of the names it "
                        "writes are replaced)")

    lanes = commands.add_parser(
        "lanes", help="the lanes a learner may start on, ranked by the traffic demand",
        epilog=EPILOG, description="List the lanes of a scenario's network that allow passenger "
        "cars (where a learner may start: [track] start_lane), ranked by the vehicles its route "
        "files send over them, with their lengths and allowed vehicle classes; and count the "
        "lanes cars may not use.")
    lanes.add_argument("source", type=_path, metavar="SCENARIO.toml|FILE.sumocfg",
                       help="a scenario, or a SUMO configuration (its network and routes)")
    lanes.add_argument("--top", type=_positive, default=20, help="lanes listed (default 20)")
    lanes.add_argument("--out", type=_path, metavar="FILE.csv", help="write every lane")
    lanes.add_argument("--plot", type=_path, metavar="FILE.png",
                       help="draw the road surface for cars against every lane as road, with "
                            "the top start lanes numbered")

    baseline = commands.add_parser(
        "baseline", help="the GA against PPO and SAC (Stable-Baselines3) at equal learner-steps",
        epilog=EPILOG, description="For each scenario: search twelve settings of each "
        "method on validation keys, then make the planned runs; each run's controller is the "
        "best of its checkpoints on 128 validation situations, scored once on 256 sealed test "
        "situations (no start shared with validation). Writes "
        "OUT/tuning.csv, comparison.csv (a row per run), situations.csv, curves.csv, "
        "training_lives.csv, comparison_summary.csv, comparison_differences.csv, "
        "comparison_rules.csv (the gaps under both spin rules), comparison.png and each "
        "run's controller in OUT/controllers/; runs already there are skipped, so the "
        "same command continues an interrupted comparison. PPO and SAC need the rl extra "
        "(pip install -e .[rl]; docs/envs.md).")
    baseline.add_argument("scenario", type=_path, nargs="+", metavar="SCENARIO.toml",
                          help="arena or navigation scenarios, or shipped ones' names")
    baseline.add_argument("--plan", default="GA:1M:10,PPO:1M:10,SAC:1M:10,GA:5M:5,PPO:5M:5",
                          help="runs as METHOD:BUDGET:SEEDS,... (METHOD GA, PPO or SAC; "
                          "default: %(default)s)")
    baseline.add_argument("--workers", type=_int_in(1, 256), default=None,
                          help="runs side by side, one core each (default: the cores, up to 8)")
    baseline.add_argument("--out", type=_path, help="folder (default: results/baseline)")
    baseline.add_argument("--quiet", action="store_true", help="no progress bar or messages")

    bench = commands.add_parser("bench", help="throughput and timing table (steps per second, "
                                "seconds)")
    bench.add_argument("--quick", action="store_true",
                       help="about a minute: shorter timings on smaller inputs, whose "
                       "rates are not comparable with the full bench's; without the rows "
                       "that compare with how things were before a change (docs/bench.md), "
                       "and without first_run, crowd_ray, reproduce_quick and bench_quick (a "
                       "whole command each, the same with or without --quick) unless --only "
                       "names them")
    bench.add_argument("--out", type=_path, metavar="FILE.csv", help="also write the table")
    bench.add_argument("--only", help="comma-separated workloads (default: all): first_run, "
                       "contention, fresh, network, sumo_step, navigation, arena, env, sb3, "
                       "sumo, recording, crowd_scale, city, lane_keeping, crowd_ray, "
                       "reproduce_quick, bench_quick, test_suite (the README's pytest in a "
                       "clone of the git checkout, cold and warm: only when named)")
    return parser


def _sumo_folder(out: Path | None) -> Path | None:
    """Where SUMO's log (and kept outputs) of ``evaluate`` or ``render`` go: ``FILE_sumo/``
    beside their output file."""
    return None if out is None else out.with_name(out.stem + "_sumo")


def _note(message: str) -> None:
    """A note on how the command reads its input, on standard error (not with --quiet)."""
    from enn_traffic.core.progress import log

    log.warning(message)


def _warn_unread(scenario, command: str) -> None:
    """Warn of keys the scenario file sets that ``command`` does not read."""
    traffic = scenario.traffic
    if traffic is not None and "learners" in traffic.model_fields_set:
        _note(f"{scenario.source}: traffic.learners = {traffic.learners} is read only by "
              f"'enn-traffic crowd' and 'reproduce' (Tables 3-4, many learners in one SUMO); "
              f"{command} "
              "drives one learner per chromosome and ignores it")
    if "crowd" in scenario.model_fields_set:
        _note(f"{scenario.source}: [crowd] is read only by 'enn-traffic crowd' and 'reproduce' "
              f"(the crowds of Tables 3-4, every vehicle driving at once); {command} ignores it")


def _check_out(out: Path) -> None:
    """A run folder this command could write and no other run writes (nothing written)."""
    from enn_traffic.core.io import check_output_folder, check_unlocked

    check_output_folder(out)
    check_unlocked(out)


def _cmd_run(args) -> int:
    from enn_traffic.config import load_scenario
    from enn_traffic.config.shipped import scenario_path
    from enn_traffic.core.progress import slow_step
    from enn_traffic.learning.evaluators import make_evaluator
    from enn_traffic.runs.run import check_folder, check_folder_unread, evolve

    if args.out:  # said before the scenario's network is read
        _check_out(args.out)
        check_folder_unread(args.out, scenario_path(args.scenario),
                            resume=args.resume, force=args.force)
    scenario = load_scenario(scenario_path(args.scenario))
    overrides = {}
    if args.generations:
        overrides["generations"] = args.generations
    if args.population:
        overrides["population_size"] = args.population
        if args.population < scenario.ga.tournament_size:  # a tournament fits its population
            overrides["tournament_size"] = args.population
            _note(f"ga.tournament_size {scenario.ga.tournament_size} lowered to "
                  f"--population {args.population}")
    _warn_unread(scenario, "run")
    scenario = scenario.with_overrides(
        **({"ga": overrides} if overrides else {}),
        **({"seed": args.seed} if args.seed is not None else {}),
    )
    out = args.out or Path("results") / scenario.name
    args.run_folder = out  # for the message of an interrupt (_interrupted_note)
    _check_out(out)  # before any world, nothing written yet
    check_folder(scenario, out, resume=args.resume, force=args.force)
    scenario = scenario.with_sumo_output(out / "sumo", console=args.verbose)
    with slow_step(f"preparing the worlds of {scenario.name}"):
        evaluator = make_evaluator(scenario, args.executor, args.address)
    try:
        table = evolve(scenario, out, evaluator, resume=args.resume, force=args.force,
                       progress=not args.quiet)  # holds the folder's lock
    finally:
        evaluator.close()
    last = table.iloc[-1]
    best = table["best_fitness"].max()
    print(f"{scenario.name}: {len(table)} generation{'s' * (len(table) != 1)}, best fitness "
          f"{best:.0f} steps "
          f"(last generation: best {last['best_fitness']:.0f}, mean {last['mean_fitness']:.1f}); "
          f"{table['vehicle_steps'].sum():,} vehicle-steps in {last['elapsed_s']:.1f} s")
    print(f"results in {out}/")
    return 0


def _cmd_crowd(args) -> int:
    from enn_traffic.config import load_scenario
    from enn_traffic.config.shipped import scenario_path
    from enn_traffic.experiments.crowds.user import (
        check_folder,
        check_room,
        crowd_scenario,
        run_crowd,
    )

    if args.out:  # said before the scenario's network is read
        _check_out(args.out)
        check_folder(args.out, resume=args.resume, force=args.force,
                     source=scenario_path(args.scenario))
    scenario = crowd_scenario(load_scenario(scenario_path(args.scenario)), args.learners,
                              args.quick)
    out = args.out or Path("results") / f"{scenario.name}_crowd"
    _check_out(out)  # before any world, nothing written yet
    check_folder(out, resume=args.resume, force=args.force, source=scenario.source)
    check_room(scenario, "--learners" if args.learners else "traffic.learners")
    scenario = scenario.with_sumo_output(out / "sumo", console=args.verbose)
    lines = run_crowd(scenario, out, args.executor, args.address,
                      resume=args.resume, force=args.force, progress=not args.quiet)
    print("\n".join(lines))
    print(f"results in {out}/")
    return 0


def _labels(paths: list[Path]) -> list[str]:
    """Short unique names for controller files: the file name without .npz, with as many
    parent folders as it takes to tell them apart."""
    for depth in range(1, max(len(p.parts) for p in paths) + 1):
        labels = ["/".join(p.with_suffix("").parts[-depth:]) for p in paths]
        if len(set(labels)) == len(labels):
            return labels
    return [str(p) for p in paths]


def _cmd_evaluate(args) -> int:
    from enn_traffic.config import load_scenario
    from enn_traffic.config.shipped import scenario_path
    from enn_traffic.core.io import check_output_file, check_output_folder, file_lock
    from enn_traffic.runs.controller import Controller
    from enn_traffic.runs.evaluate import evaluate_batch, matrix_files

    controller_paths = [p for p in args.paths if p.suffix == ".npz"]
    scenario_paths = [p for p in args.paths if p.suffix == ".toml"]
    if args.out:  # every file it will write, before any work
        check_output_file(args.out, suffixes=(".csv",))
        if len(controller_paths) * len(scenario_paths) > 1:
            for written in matrix_files(args.out):
                check_output_file(written)
        check_output_folder(_sumo_folder(args.out))
    for path in args.paths:
        if path.suffix not in (".npz", ".toml"):
            raise InputError("expected controllers (.npz) and scenarios (.toml)", path)
    if not controller_paths or not scenario_paths:
        raise InputError("give at least one controller (.npz) and one scenario (.toml)",
                         key="evaluate")
    controllers = {label: Controller.load(path) for label, path
                   in zip(_labels(controller_paths), controller_paths, strict=True)}
    scenarios = [load_scenario(scenario_path(path)) for path in scenario_paths]
    named: dict[str, Path] = {}
    for path, scenario in zip(scenario_paths, scenarios, strict=True):
        if scenario.name in named and scenario.source != named[scenario.name]:
            raise InputError(f"has the name {scenario.name!r} of {named[scenario.name]}: the "
                             "table would mix their situations in one column; give each "
                             "scenario its own name", path, "name")
        named[scenario.name] = scenario.source
    if args.mode:
        if not any(s.traffic.is_sumo for s in scenarios):
            raise InputError('--mode applies to SUMO traffic (traffic.strategy = "sumo")',
                             scenario_paths[0], "traffic.strategy")
        scenarios = [s.with_overrides(traffic={"mode": args.mode}) if s.traffic.is_sumo else s
                     for s in scenarios]
    if args.traffic_seed is not None:
        # lane keeping has no traffic: its situations come from the scenario's seed alone
        scenarios = [s if s.lane_keeping is not None
                     else s.with_overrides(traffic={"seed": args.traffic_seed})
                     for s in scenarios]
    scenarios = [s.with_sumo_output(_sumo_folder(args.out), args.verbose) for s in scenarios]
    with file_lock(args.out) if args.out else contextlib.nullcontext():
        table = evaluate_batch(controllers, scenarios, args.episodes, args.executor,
                               args.address, progress=not args.quiet)
        _show_and_write(table, controllers, scenarios, args.out)
    return 0


def _show_and_write(table, controllers: dict, scenarios: list, out: Path | None) -> None:
    """``evaluate``'s table on the terminal, and into ``out`` (with its matrix files when
    several pairs ran)."""
    from enn_traffic.core.io import write_csv
    from enn_traffic.runs.evaluate import fitness_matrix, write_batch

    single = len(controllers) == 1 and len(scenarios) == 1
    if single:
        print(table.drop(columns="controller").to_string(index=False))
    else:
        print(fitness_matrix(table).round(1).to_string())
    if out:
        written = [out] if single else write_batch(table, out)
        if single:
            write_csv(out, table)
        print("written " + ", ".join(str(p) for p in written))


def _cmd_render(args) -> int:
    from enn_traffic.config import load_scenario
    from enn_traffic.config.shipped import scenario_path
    from enn_traffic.core.io import check_not_input, check_output_file, check_output_folder
    from enn_traffic.runs.controller import Controller
    from enn_traffic.runs.evaluate import render

    check_output_file(args.out, suffixes=(".png", ".gif", ".svg", ".pdf"))
    check_not_input(args.out, [args.controller, args.scenario])
    check_output_folder(_sumo_folder(args.out))
    controller = Controller.load(args.controller)
    scenario = load_scenario(scenario_path(args.scenario)).with_sumo_output(
        _sumo_folder(args.out), args.verbose)
    info = render(controller, scenario, args.out, args.max_steps, progress=not args.quiet)
    print(f"{info['steps']} steps ({info['outcome']}); written {info['file']}")
    return 0


def _cmd_lanes(args) -> int:
    from enn_traffic.config import sumo_sources
    from enn_traffic.config.shipped import scenario_path
    from enn_traffic.core.io import check_output_file, write_csv
    from enn_traffic.roads.lanes import lane_table
    from enn_traffic.roads.network import ANYWHERE_AHEAD_M

    if args.out:
        check_output_file(args.out, suffixes=(".csv",))
    if args.plot:
        check_output_file(args.plot, "--plot", suffixes=(".png", ".svg", ".pdf"))
    net, routes, additional, shortest = sumo_sources(scenario_path(args.source))
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
          f"SUMO routes them ({demand}):")
    columns = ["lane", "edge", "vehicles", "length_m", "speed_limit_kmh", "allowed"]
    ranked = learner[columns].assign(rank=range(1, len(learner) + 1))
    print(ranked.head(args.top)[["rank", *columns]].to_string(index=False))
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
        _plot_lanes(net, learner.head(min(args.top, 9)), args.plot)
        print(f"written {args.plot}")
    return 0


def _scenario_starts(source, table):
    """A scenario file's own start lanes, when it names them (``start_lane`` or
    ``start_edge``, not ``auto``): (its key as written, their rows of ``table``)."""
    import tomllib

    from enn_traffic.config import load_scenario

    if source.suffix == ".sumocfg":
        return None
    written = tomllib.loads(source.read_text()).get("track", {})
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


def _cmd_reproduce(args) -> int:
    from enn_traffic.core.io import check_output_folder
    from enn_traffic.experiments.reproduce import reproduce

    check_output_folder(args.out)
    names = None
    if args.only is not None:
        names = [n.strip() for n in args.only.split(",") if n.strip()]
        if not names:
            raise InputError(f"names no experiment: {args.only!r}", key="--only")
    reproduce(args.out, quick=args.quick, only=names, progress=not args.quiet,
              executor=args.executor, address=args.address)
    return 0


def _cmd_baseline(args) -> int:
    from enn_traffic.config import load_scenario
    from enn_traffic.config.shipped import scenario_path
    from enn_traffic.core.io import check_output_folder, check_unlocked, folder_lock
    from enn_traffic.experiments.gradient_rl import campaign as baseline

    plan = baseline.parse_plan(args.plan)
    scenarios = [load_scenario(scenario_path(name)) for name in args.scenario]
    for scenario in scenarios:
        if scenario.world_kind != "arena":
            raise InputError(f"{scenario.name}: baseline compares on arena and navigation "
                             "scenarios (the compiled vector environment)")
    out = args.out or Path("results/baseline")
    check_output_folder(out)
    check_unlocked(out)
    with folder_lock(out):
        baseline.compare(scenarios, out, plan, args.workers or baseline.default_workers(),
                         progress=not args.quiet)
    print(baseline.summary_text(out))
    return 0


def _cmd_bench(args) -> int:
    from enn_traffic.bench import run_bench, table_text, workloads
    from enn_traffic.core.io import check_output_file, write_csv

    if args.out:
        check_output_file(args.out, suffixes=(".csv",))
    only = None
    if args.only is not None:
        only = [n.strip() for n in args.only.split(",") if n.strip()]
        unknown = sorted(set(only) - set(workloads()))
        if not only or unknown:
            raise InputError(f"names no workload: {', '.join(unknown) or repr(args.only)} "
                             f"(workloads: {', '.join(workloads())})", key="--only")
    table = run_bench(quick=args.quick, only=only)
    print(table_text(table))
    if args.out:
        write_csv(args.out, table)
    return 0


COMMANDS = {"run": _cmd_run, "crowd": _cmd_crowd, "evaluate": _cmd_evaluate,
            "render": _cmd_render,
            "reproduce": _cmd_reproduce, "lanes": _cmd_lanes, "baseline": _cmd_baseline,
            "bench": _cmd_bench}


# What an interrupted command leaves (the others leave nothing finished).
INTERRUPTED = {"run": "; finished generations are checkpointed (continue with --resume)",
               "reproduce": "; finished runs and experiments are kept: the same command "
                            "continues",
               "crowd": "; the individual run's generations and finished situations are "
                        "kept (continue with --resume)",
               "baseline": "; finished runs are kept in OUT/comparison.csv: the same command "
                           "continues"}


def _interrupted_note(args) -> str:
    """What an interrupted command leaves: a run says whether a generation had finished."""
    if args.command == "run":
        from enn_traffic.runs.run import CHECKPOINT

        folder = getattr(args, "run_folder", None)
        if folder is None or not (folder / CHECKPOINT).exists():
            return "; no generation had finished: nothing to resume"
    return INTERRUPTED.get(args.command, "")


def main(argv: list[str] | None = None) -> int:
    from enn_traffic.core.progress import show_messages

    args = build_parser().parse_args(argv)
    show_messages(quiet=getattr(args, "quiet", False))
    handlers, hook = {}, sys.unraisablehook
    stopping.reset()
    if threading.current_thread() is threading.main_thread():
        # a job started with & by a script inherits SIGINT ignored: kill -INT must stop it;
        # SIGTERM (kill, a batch system's time limit) stops a command as Ctrl-C does
        handlers = {signal.SIGINT: signal.signal(signal.SIGINT, _interrupt),
                    signal.SIGTERM: signal.signal(signal.SIGTERM, _terminate)}
        sys.unraisablehook = stopping.unraisable
    try:
        return _run_command(args)
    finally:
        for number, handler in handlers.items():
            signal.signal(number, handler)
        sys.unraisablehook = hook
        stopping.reset()


class Terminated(KeyboardInterrupt):
    """SIGTERM, met as Ctrl-C is: the command stops where it is and says so."""


def _interrupt(number, frame) -> None:
    stopping.request(KeyboardInterrupt)


def _terminate(number, frame) -> None:
    stopping.request(Terminated)


def _run_command(args) -> int:
    started = time.perf_counter()
    try:
        return COMMANDS[args.command](args)
    except InputError as exc:  # one line, whatever SUMO's message spans
        print(f"enn-traffic: error: {' '.join(str(exc).split())}", file=sys.stderr)
        return 2
    except BrokenPipeError:  # output piped into a reader that stopped early (e.g. head)
        sys.stderr.close()
        return 0
    except OSError as exc:  # a file that could not be read or written: a full disk, a lost mount
        if exc.errno not in _FILE_TROUBLE:
            raise
        where = f"{exc.filename}: " if exc.filename else ""
        print(f"enn-traffic: error: {where}{exc.strerror or exc}", file=sys.stderr)
        return 2
    except (KeyboardInterrupt, SystemError) as exc:
        cause = _interrupted(exc)
        if cause is None:
            raise
        stopped = "terminated" if isinstance(cause, Terminated) else "interrupted"
        print(f"\nenn-traffic: {stopped} after {time.perf_counter() - started:.0f} s"
              f"{_interrupted_note(args)}", file=sys.stderr)
        return 143 if isinstance(cause, Terminated) else 130


_FILE_TROUBLE = {errno.ENOSPC, errno.EDQUOT, errno.EROFS, errno.EACCES, errno.EPERM,
                 errno.EFBIG, errno.EIO, errno.ENOENT, errno.ENOTDIR, errno.EISDIR, errno.ELOOP,
                 errno.ENAMETOOLONG}


def _interrupted(exc: BaseException | None) -> KeyboardInterrupt | None:
    """The Ctrl-C (or SIGTERM) behind ``exc``, if any. (One that lands inside a compiled
    kernel comes out of numba as a SystemError caused by it.)"""
    while exc is not None:
        if isinstance(exc, KeyboardInterrupt):
            return exc
        exc = exc.__cause__ or exc.__context__
    return None


if __name__ == "__main__":
    sys.exit(main())
