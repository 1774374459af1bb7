"""``enn-traffic evaluate``: saved controllers on scenarios' held-out traffic."""

from __future__ import annotations

import contextlib
from pathlib import Path

from enn_traffic.cli.args import EPILOG, episodes, nonempty_path, note, seed, sumo_folder
from enn_traffic.core.errors import InputError


def add_parser(commands) -> None:
    """The command's arguments."""
    command = commands.add_parser(
        "evaluate", help="run saved controllers on scenarios", epilog=EPILOG,
        description="Run each controller on each scenario's held-out traffic situations. One "
        "pair prints its lifetimes; several print the controller x scenario matrix of mean "
        "fitness. --out FILE.csv writes every situation (tidy) and, for several pairs, "
        "FILE_matrix.csv and FILE_matrix.png (heat map).")
    command.add_argument("paths", type=nonempty_path, nargs="+",
                         metavar="CONTROLLER.npz|SCENARIO.toml",
                         help="controllers (.npz) and scenarios (.toml): one or more of each, "
                              "in any order")
    command.add_argument("--episodes", metavar="N", type=episodes, default=1,
                         help="traffic situations per pair (default 1)")
    command.add_argument("--out", type=nonempty_path, metavar="FILE.csv",
                         help="write the lifetimes")
    command.add_argument("--mode", choices=["replay", "closed-loop"],
                         help="SUMO traffic: replayed, or reacting to the controller "
                              "(default: the scenario's traffic.mode)")
    command.add_argument("--traffic-seed", type=seed, metavar="N",
                         help="traffic seed (default: each scenario's traffic.seed); another "
                         "seed gives traffic situations that no training or choice drew "
                         "(lane keeping has no traffic: it ignores this)")
    command.add_argument("--executor", choices=["local", "process", "ray"], default="local",
                         help="where the pairs run (default: local, one after another)")
    command.add_argument("--address", metavar="ADDR",
                         help="Ray cluster address (with --executor ray)")
    command.add_argument("--quiet", action="store_true", help="no progress bar or messages")
    command.add_argument("--verbose", action="store_true",
                         help="show SUMO's console instead of logging it (to FILE_sumo/ "
                              "beside --out)")


def _is_scenario(path: Path) -> bool:
    """A scenario file, or the bare name of a shipped scenario (no suffix, no such file)."""
    return path.suffix == ".toml" or (not path.suffix and not path.exists())


def run(args) -> int:
    from enn_traffic.config import load_scenario
    from enn_traffic.config.shipped import scenario_path
    from enn_traffic.core.io import check_output_file, check_output_folder, file_lock
    from enn_traffic.runs.controller import Controller
    from enn_traffic.runs.evaluate import evaluate_batch, matrix_files

    controller_paths = [p for p in args.paths if p.suffix == ".npz"]
    scenario_paths = [p for p in args.paths if _is_scenario(p)]
    if args.out:  # every file it will write, before any work
        check_output_file(args.out, suffixes=(".csv",))
        if len(controller_paths) * len(scenario_paths) > 1:
            for written in matrix_files(args.out):
                check_output_file(written)
        check_output_folder(sumo_folder(args.out))
    for path in args.paths:
        if path.suffix != ".npz" and not _is_scenario(path):
            raise InputError("expected controllers (.npz) and scenarios (.toml, or a shipped "
                             "scenario's name)", path)
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
    scenarios = [s.with_sumo_output(sumo_folder(args.out), args.verbose) for s in scenarios]
    with file_lock(args.out) if args.out else contextlib.nullcontext():
        table = evaluate_batch(controllers, scenarios, args.episodes, args.executor,
                               args.address, progress=not args.quiet)
        _show_and_write(table, controllers, scenarios, args.out)
    return 0


def _labels(paths: list[Path]) -> list[str]:
    """Short unique names for controller files: the file name without .npz, with as many
    parent folders as it takes to tell them apart."""
    for depth in range(1, max(len(p.parts) for p in paths) + 1):
        labels = ["/".join(p.with_suffix("").parts[-depth:]) for p in paths]
        if len(set(labels)) == len(labels):
            return labels
    return [str(p) for p in paths]


def _show_and_write(table, controllers: dict, scenarios: list, out: Path | None) -> None:
    """``evaluate``'s table on the terminal, and into ``out`` (with its matrix files when
    several pairs ran)."""
    from enn_traffic.core.io import write_csv
    from enn_traffic.runs.evaluate import distinct_starts, fitness_matrix, write_batch

    single = len(controllers) == 1 and len(scenarios) == 1
    if single:
        print(table.drop(columns="controller").to_string(index=False))
    else:
        print(fitness_matrix(table).round(1).to_string())
    distinct, situations = distinct_starts(table)
    if distinct < situations:
        counted = ("" if single else "; the matrix counts each starting state once")
        note(f"only {distinct} of {situations} situations start from distinct states: "
             "situations sharing a warm-up and the learner's start (same_start_as) differ "
             f"only by what SUMO draws after it{counted}. Raise traffic.warmup_states for "
             "more distinct ones.")
    if out:
        written = [out] if single else write_batch(table, out)
        if single:
            write_csv(out, table)
        print("written " + ", ".join(str(p) for p in written))
