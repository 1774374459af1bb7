"""``enn-traffic render``: a controller's path drawn (PNG) or animated (GIF)."""

from __future__ import annotations

from enn_traffic.cli.args import EPILOG, nonempty_path, steps, sumo_folder


def add_parser(commands) -> None:
    """The command's arguments."""
    command = commands.add_parser("render", help="draw a controller's path (PNG) or animate it "
                                  "(GIF)", epilog=EPILOG)
    command.add_argument("controller", type=nonempty_path, metavar="CONTROLLER.npz")
    command.add_argument("scenario", type=nonempty_path, metavar="SCENARIO.toml")
    command.add_argument("--out", type=nonempty_path, required=True, metavar="FILE.png|FILE.gif")
    command.add_argument("--max-steps", metavar="N", type=steps, default=5000,
                         help="draw at most this many steps (default 5000)")
    command.add_argument("--quiet", action="store_true", help="no progress bar or messages")
    command.add_argument("--verbose", action="store_true",
                         help="show SUMO's console instead of logging it (to FILE_sumo/ beside "
                              "--out)")


def run(args) -> int:
    from enn_traffic.config import load_scenario
    from enn_traffic.config.shipped import scenario_path
    from enn_traffic.core.io import check_not_input, check_output_file, check_output_folder
    from enn_traffic.runs.controller import Controller
    from enn_traffic.runs.evaluate import render

    check_output_file(args.out, suffixes=(".png", ".gif", ".svg", ".pdf"))
    check_not_input(args.out, [args.controller, args.scenario])
    check_output_folder(sumo_folder(args.out))
    controller = Controller.load(args.controller)
    scenario = load_scenario(scenario_path(args.scenario)).with_sumo_output(
        sumo_folder(args.out), args.verbose)
    info = render(controller, scenario, args.out, args.max_steps, progress=not args.quiet)
    print(f"{info['steps']} steps ({info['outcome']}); written {info['file']}")
    return 0
