"""``enn-traffic baseline``: the GA against PPO and SAC at equal learner-steps."""

from __future__ import annotations

from pathlib import Path

from enn_traffic.cli.args import EPILOG, int_in, nonempty_path
from enn_traffic.core.errors import InputError

# What an interrupted baseline leaves.
INTERRUPTED = ("; finished runs are kept in OUT/comparison.csv: the same command "
               "continues")


def add_parser(commands) -> None:
    """The command's arguments."""
    command = commands.add_parser(
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
    command.add_argument("scenario", type=nonempty_path, nargs="+", metavar="SCENARIO.toml",
                         help="arena or navigation scenarios, or shipped ones' names")
    command.add_argument("--plan", default="GA:1M:10,PPO:1M:10,SAC:1M:10,GA:5M:5,PPO:5M:5",
                         help="runs as METHOD:BUDGET:SEEDS,... (METHOD GA, PPO or SAC; "
                         "default: %(default)s)")
    command.add_argument("--workers", metavar="N", type=int_in(1, 256), default=None,
                         help="runs side by side, one core each (default: the cores, up to 8)")
    command.add_argument("--out", metavar="DIR", type=nonempty_path,
                         help="folder (default: results/baseline)")
    command.add_argument("--quiet", action="store_true", help="no progress bar or messages")


def run(args) -> int:
    from enn_traffic.config import load_scenario
    from enn_traffic.config.shipped import scenario_path
    from enn_traffic.core.io import check_output_folder, check_unlocked, folder_lock
    from enn_traffic.experiments.gradient_rl import campaign, protocol

    plan = protocol.parse_plan(args.plan)
    scenarios = [load_scenario(scenario_path(name)) for name in args.scenario]
    for scenario in scenarios:
        if scenario.world_kind != "arena":
            raise InputError(f"{scenario.name}: baseline compares on arena and navigation "
                             "scenarios (the compiled vector environment)")
    out = args.out or Path("results/baseline")
    check_output_folder(out)
    _not_another_commands(out)
    check_unlocked(out)
    with folder_lock(out):
        campaign.compare(scenarios, out, plan, args.workers or campaign.default_workers(),
                         progress=not args.quiet)
    print(campaign.summary_text(out))
    return 0


def _not_another_commands(out: Path) -> None:
    """Refuse a folder that holds a run or a crowd (``run`` and ``crowd`` refuse each other's
    folders too): a comparison's files would be mixed in among theirs."""
    from enn_traffic.experiments.crowds.user import MARKER
    from enn_traffic.runs.run import CHECKPOINT

    for name, what in ((CHECKPOINT, "a run"), (MARKER, "a crowd run")):
        if (out / name).is_file():
            raise InputError(f"holds {what} ({name}); a comparison writes a folder of its own: "
                             "give another --out", out, "--out")
