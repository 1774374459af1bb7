"""What the commands share: argparse types with the schema's bounds, the options of a command
that writes a run folder, a parser whose errors are one line, and notes on how a command reads
its input."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

EPILOG = "Scenario files are described in docs/scenarios.md."


def int_in(minimum: int, maximum: int | None = None):
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


def nonempty_path(text: str) -> Path:
    """An argparse type: a path, never empty (an empty one would be the current folder)."""
    if not text.strip():
        raise argparse.ArgumentTypeError("expected a path, got an empty one")
    return Path(text)


positive, non_negative = int_in(1), int_in(0)
seed = int_in(0, 2**63 - 1)  # scenario.MAX_SEED: seeds are mixed into 64-bit keys
# The schema's own bounds, written again so that --help need not import it (a test compares):
# ga.generations, ga.population_size, episode.max_steps, traffic.episodes
count, population = int_in(1, 100_000), int_in(2, 100_000)
steps, episodes = int_in(1, 10_000_000), int_in(1, 1000)


def run_folder_options(command: argparse.ArgumentParser, resume: str, force: str) -> None:
    """--resume or --force, --quiet and --verbose: a command that writes a run folder."""
    again = command.add_mutually_exclusive_group()
    again.add_argument("--resume", action="store_true", help=resume)
    again.add_argument("--force", action="store_true", help=force)
    command.add_argument("--quiet", action="store_true", help="no progress bar or messages")
    command.add_argument("--verbose", action="store_true",
                         help="show SUMO's console instead of logging it to OUT/sumo/sumo.log")


class Parser(argparse.ArgumentParser):
    """argparse with a bad command line as every other error: one line, ``enn-traffic:
    error: ...`` (the command named in it), exit status 2; ``--help`` shows the usage."""

    def error(self, message: str):
        command = self.prog.removeprefix("enn-traffic").strip()
        print(f"enn-traffic: error: {command + ': ' if command else ''}{message} "
              f"(see {self.prog} --help)", file=sys.stderr)
        raise SystemExit(2)


def sumo_folder(out: Path | None) -> Path | None:
    """Where SUMO's log (and kept outputs) of ``evaluate`` or ``render`` go: ``FILE_sumo/``
    beside their output file."""
    return None if out is None else out.with_name(out.stem + "_sumo")


def note(message: str) -> None:
    """A note on how the command reads its input, on standard error (not with --quiet)."""
    from enn_traffic.core.progress import log

    log.warning(message)


def warn_unread(scenario, command: str) -> None:
    """Warn of keys the scenario file sets that ``command`` does not read."""
    traffic = scenario.traffic
    if traffic is not None and "learners" in traffic.model_fields_set:
        note(f"{scenario.source}: traffic.learners = {traffic.learners} is read only by "
             f"'enn-traffic crowd' and 'reproduce' (Tables 3-4, many learners in one SUMO); "
             f"{command} "
             "drives one learner per chromosome and ignores it")
    if "crowd" in scenario.model_fields_set:
        note(f"{scenario.source}: [crowd] is read only by 'enn-traffic crowd' and 'reproduce' "
             f"(the crowds of Tables 3-4, every vehicle driving at once); {command} ignores it")


def check_out(out: Path) -> None:
    """A run folder this command could write and no other run writes (nothing written)."""
    from enn_traffic.core.io import check_output_folder, check_unlocked

    check_output_folder(out)
    check_unlocked(out)
