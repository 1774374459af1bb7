"""``enn-traffic run``: evolve a controller on a scenario (one checkpointed GA run)."""

from __future__ import annotations

from pathlib import Path

from enn_traffic.cli.args import (
    EPILOG,
    check_out,
    count,
    nonempty_path,
    note,
    population,
    run_folder_options,
    seed,
    warn_unread,
)

# What an interrupted run leaves.
INTERRUPTED = ("; finished generations are checkpointed (continue with --resume)")


def add_parser(commands) -> None:
    """The command's arguments."""
    command = commands.add_parser("run", help="evolve a controller on a scenario", epilog=EPILOG,
                                  description="Evolve a controller; writes scenario.toml, "
                                  "generations.csv, best.npz, learning_curve.png, outputs.npz and "
                                  "a checkpoint.")
    command.add_argument("scenario", type=nonempty_path, metavar="SCENARIO.toml",
                         help="a scenario file, or a shipped scenario's name (navigation_narrow)")
    command.add_argument("--out", metavar="DIR", type=nonempty_path,
                         help="run folder (default: results/<scenario name>)")
    command.add_argument("--seed", metavar="N", type=seed, help="override the scenario's seed")
    command.add_argument("--generations", metavar="N", type=count, help="override ga.generations")
    command.add_argument("--population", metavar="N", type=population,
                         help="override ga.population_size")
    command.add_argument("--executor", choices=["local", "process", "ray"], default="local",
                         help="where fitness is evaluated (default: local, in-process)")
    command.add_argument("--address", metavar="ADDR",
                         help="Ray cluster address (with --executor ray)")
    run_folder_options(command, "continue the run in the folder from its checkpoint",
                       "start over even if the folder holds another run")


def run(args) -> int:
    from enn_traffic.config import load_scenario
    from enn_traffic.config.shipped import scenario_path
    from enn_traffic.core.errors import InputError
    from enn_traffic.core.progress import slow_step
    from enn_traffic.learning.evaluators import make_evaluator
    from enn_traffic.runs.run import CHECKPOINT, check_folder, check_folder_unread, evolve

    if args.out:  # said before the scenario's network is read
        check_out(args.out)
        check_folder_unread(args.out, scenario_path(args.scenario),
                            resume=args.resume, force=args.force)
    scenario = load_scenario(scenario_path(args.scenario))
    overrides = {}
    if args.generations:
        overrides["generations"] = args.generations
    if args.population:
        if args.population <= scenario.ga.elite_count:  # named as the option, not the file's key
            raise InputError(f"{args.population} is not above the scenario's ga.elite_count "
                             f"({scenario.ga.elite_count}, {scenario.source.name}): give a "
                             "larger population, or lower elite_count there", key="--population")
        overrides["population_size"] = args.population
        lowered = args.population < scenario.ga.tournament_size
        if lowered:  # a tournament fits its population
            overrides["tournament_size"] = args.population
    warn_unread(scenario, "run")
    tournament = scenario.ga.tournament_size
    scenario = scenario.with_overrides(  # a bad --population is refused before any note
        **({"ga": overrides} if overrides else {}),
        **({"seed": args.seed} if args.seed is not None else {}),
    )
    if args.population and lowered:
        note(f"ga.tournament_size {tournament} lowered to --population {args.population}")
    out = args.out or Path("results") / scenario.name
    args.run_folder = out  # for the message of an interrupt (_interrupted_note)
    check_out(out)  # before any world, nothing written yet
    check_folder(scenario, out, resume=args.resume, force=args.force)
    if args.resume and not (out / CHECKPOINT).exists():  # a mistyped --out shows here
        note(f"{out} holds no run to resume: starting one")
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
