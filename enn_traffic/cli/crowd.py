"""``enn-traffic crowd``: every vehicle learning at once in a SUMO scenario (Tables 3–4)."""

from __future__ import annotations

from pathlib import Path

from enn_traffic.cli.args import EPILOG, check_out, int_in, nonempty_path, run_folder_options
from enn_traffic.config.base import MAX_LEARNERS

# What an interrupted crowd leaves.
INTERRUPTED = ("; the individual run's generations and finished situations are "
               "kept (continue with --resume)")


def add_parser(commands) -> None:
    """The command's arguments."""
    command = commands.add_parser(
        "crowd", help="every vehicle learning at once in a SUMO scenario (Tables 3-4)",
        epilog=EPILOG, description="Tables 3-4 of the paper on your SUMO scenario: the "
        "scenario's GA evolves a winner among SUMO's traffic (OUT/individual/, as run writes "
        "it), then traffic.learners vehicles drive at once in one SUMO, closed loop, in each "
        "of crowd.situations test situations: initial drivers, the winner for all, and every "
        "vehicle evolving on. Writes OUT/table3.csv, table4.csv, table4_learners.csv, "
        "table4_learning.csv and .png, table4_learning_ends.csv, crowd_situations.csv, "
        "table4_validation_learners.csv, controllers/ and crowd.gif (docs/sumo.md, 'Every car "
        "learning in your city').")
    command.add_argument("scenario", type=nonempty_path, metavar="SCENARIO.toml",
                         help="a SUMO scenario file, or a shipped one's name (sumo_strategy1)")
    command.add_argument("--out", metavar="DIR", type=nonempty_path,
                         help="folder (default: results/<scenario name>_crowd)")
    command.add_argument("--learners", metavar="N", type=int_in(1, MAX_LEARNERS),
                         help="override traffic.learners (vehicles learning in one SUMO)")
    command.add_argument("--quick", action="store_true",
                         help="minutes: 2 generations of the GA, 20 s of learning in 10 s "
                              "windows, 2 situations, 1 validation situation (too short to "
                              "breed: a check that it runs)")
    command.add_argument("--executor", choices=["local", "process", "ray"], default="local",
                         help="where the GA's fitness is evaluated and, with ray, the "
                              "situations run side by side (default: local)")
    command.add_argument("--address", metavar="ADDR",
                         help="Ray cluster address (with --executor ray)")
    run_folder_options(command, "continue the crowd run in the folder",
                       "start over, even in a folder of other files (those of the names it "
                       "writes are replaced)")


def run(args) -> int:
    from enn_traffic.config import load_scenario
    from enn_traffic.config.shipped import scenario_path
    from enn_traffic.experiments.crowds.user import check_folder, crowd_scenario, run_crowd
    from enn_traffic.sim.sumo.crowd import check_room
    from enn_traffic.sim.sumo.world import SumoWorld

    if args.out:  # said before the scenario's network is read
        check_out(args.out)
        check_folder(args.out, resume=args.resume, force=args.force,
                     source=scenario_path(args.scenario))
    scenario = crowd_scenario(load_scenario(scenario_path(args.scenario)), args.learners,
                              args.quick)
    out = args.out or Path("results") / f"{scenario.name}_crowd"
    check_out(out)  # before any world, nothing written yet
    check_folder(out, resume=args.resume, force=args.force, source=scenario.source)
    check_room(SumoWorld(scenario.with_overrides(traffic={"mode": "closed-loop"})),
               "--learners" if args.learners else "traffic.learners")
    scenario = scenario.with_sumo_output(out / "sumo", console=args.verbose)
    lines = run_crowd(scenario, out, args.executor, args.address,
                      resume=args.resume, force=args.force, progress=not args.quiet)
    print("\n".join(lines))
    print(f"results in {out}/")
    return 0
