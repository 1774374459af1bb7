"""The numbers the documents state that no table holds, written by the experiments that own
them: each a small JSON file, ``facts/NAME.json`` in the results folder the experiment
writes (docs/_generate/README.md). A document renders only what files hold, so a statistic
(a bootstrap interval, a count over saved controllers, a choice made from a table) is
computed here, once, by the experiment's own code, never by the documents.

``python -m enn_traffic.experiments.facts [RESULTS]`` writes every facts file from the tables
under ``RESULTS`` (default: ``results``); ``--check`` writes nothing and exits 1 where a
committed file differs from what its tables give.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from enn_traffic.core.io import write_text
from enn_traffic.core.registry import Registry

# Each facts file by "KIND/NAME": the function that computes it from a results folder of that
# kind (``reproduce``'s, ``baseline``'s, ``crowd``'s; ``baseline_round2``: the comparison's
# second round, a finished folder no command writes again), ``(folder: Path) -> dict`` of JSON
# values.
FACTS = Registry("facts", {
    "paper/table1": "enn_traffic.experiments.table1:facts",
    "paper/lane_keeping": "enn_traffic.experiments.lanekeeping:road_facts",
    "paper/tables34": "enn_traffic.experiments.crowds.arena:facts",
    "paper/table4_ablation": "enn_traffic.experiments.ablation:facts",
    "paper/sumo_tables34": "enn_traffic.experiments.crowds.sumo:sumo_facts",
    "paper/city_tables34": "enn_traffic.experiments.crowds.sumo:city_facts",
    "paper/verdicts": "enn_traffic.experiments.verdicts:paper_facts",
    "baseline/plan": "enn_traffic.experiments.gradient_rl.facts:plan",
    "baseline/starts": "enn_traffic.experiments.gradient_rl.facts:starts",
    "baseline/track": "enn_traffic.experiments.gradient_rl.facts:track",
    "baseline/spin_rule": "enn_traffic.experiments.gradient_rl.facts:spin_rule",
    "baseline/search": "enn_traffic.experiments.gradient_rl.facts:search",
    "baseline/fitness": "enn_traffic.experiments.gradient_rl.facts:fitness",
    "baseline/ablations": "enn_traffic.experiments.gradient_rl.facts:ablations",
    "baseline/stopping": "enn_traffic.experiments.gradient_rl.facts:stopping",
    "baseline/verdict": "enn_traffic.experiments.verdicts:baseline_facts",
    "baseline_round2/starts": "enn_traffic.experiments.gradient_rl.facts:round2_starts",
    "baseline_round2/settings": "enn_traffic.experiments.gradient_rl.facts:round2_settings",
    "baseline_round2/networks": "enn_traffic.experiments.gradient_rl.facts:round2_networks",
    "baseline_round2/levels": "enn_traffic.experiments.gradient_rl.facts:round2_levels",
})
# The committed results folder of each kind, under the repository's results/.
FOLDERS = {"paper": "paper", "baseline": "baseline", "baseline_round2": "baseline_round2",
           "crowd": "crowd_brunswick"}


def path_of(folder: Path, name: str) -> Path:
    """Where facts file ``name`` ("KIND/NAME") lies in a results ``folder`` of its kind."""
    return folder / "facts" / f"{name.partition('/')[2]}.json"


def read(folder: Path, name: str | None = None) -> dict:
    """Facts file ``name`` of a results ``folder`` as written (its name within the folder:
    ``table1``), or, without a name, every facts file of the folder by that name."""
    if name is not None:
        return json.loads((folder / "facts" / f"{name}.json").read_text(encoding="utf-8"))
    return {path.stem: json.loads(path.read_text(encoding="utf-8"))
            for path in sorted((folder / "facts").glob("*.json"))}


def computed(folder: Path, name: str) -> dict:
    """Facts file ``name`` as its function computes it from the tables in ``folder`` (a
    JSON round trip: what the file would hold)."""
    return json.loads(json.dumps(FACTS[name](folder)))


def write(folder: Path, name: str) -> Path:
    """Write facts file ``name`` from the tables in ``folder``."""
    path = path_of(folder, name)
    path.parent.mkdir(parents=True, exist_ok=True)
    write_text(path, json.dumps(computed(folder, name), indent=1, sort_keys=True) + "\n")
    return path


def write_all(folder: Path, kind: str) -> list[Path]:
    """Every facts file of ``kind`` (``paper``, ``baseline`` ...) whose tables ``folder``
    holds, as a command writes them after its own tables."""
    written = []
    for name in FACTS:
        if name.partition("/")[0] == kind:
            try:
                written.append(write(folder, name))
            except FileNotFoundError:  # an experiment not run into this folder
                continue
    return written


def differences(root: Path) -> list[str]:
    """The facts files under the results ``root`` that differ from what their tables give."""
    found = []
    for name in FACTS:
        folder = root / FOLDERS[name.partition("/")[0]]
        path = path_of(folder, name)
        written = json.loads(path.read_text(encoding="utf-8")) if path.is_file() else None
        if written != computed(folder, name):
            found.append(str(path))
    return found


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("results", nargs="?", type=Path, default=Path("results"))
    parser.add_argument("--check", action="store_true")
    args = parser.parse_args(argv)
    if args.check:
        found = differences(args.results)
        for path in found:
            print(f"{path} differs from what its tables give", file=sys.stderr)
        return 1 if found else 0
    for name in FACTS:
        folder = args.results / FOLDERS[name.partition("/")[0]]
        print(f"wrote {write(folder, name)}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
