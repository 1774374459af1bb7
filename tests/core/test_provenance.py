"""Which digests move with which edits: numba's compiled kernels are kept until a source they
compile from changes, not when a report or an experiment does."""

import shutil

from enn_traffic.core.provenance import PACKAGE, code_version, kernels_version


def test_kernels_version_moves_with_the_kernels_sources_only(tmp_path):
    package = tmp_path / "enn_traffic"
    shutil.copytree(PACKAGE, package, ignore=shutil.ignore_patterns("__pycache__"))
    kernels, code = kernels_version(package), code_version(package)

    def edit(relative: str, text: str) -> None:
        with open(package / relative, "a") as handle:
            handle.write(text)

    edit("experiments/study.py", "\nA_REPORTS_EDIT = 1\n")
    assert kernels_version.__wrapped__(package) == kernels
    assert code_version.__wrapped__(package) != code
    edit("sim/world.py", "\n# a constant kernels read may change here\n")
    moved = kernels_version.__wrapped__(package)
    assert moved != kernels
    edit("experiments/regime.py", "\nfrom numba import njit\n\n\n@njit\ndef kernel():\n"
         "    return 1\n")
    assert kernels_version.__wrapped__(package) != moved


def test_the_rules_digest_follows_the_code_not_its_files(tmp_path):
    """A comment, a docstring, an import or a move of code into another file leaves the rules'
    digest (and so every run's fingerprint) as it was; a changed number moves it."""
    from enn_traffic.core.provenance import rules_version

    package = tmp_path / "enn_traffic"
    shutil.copytree(PACKAGE, package, ignore=shutil.ignore_patterns("__pycache__"))
    rules = rules_version.__wrapped__(package)
    bicycle, step = package / "sim" / "bicycle.py", package / "sim" / "rules.py"
    text = step.read_text()
    step.write_text(text.replace('"""', '"""A docstring edited. ', 1) + "\n# a comment\n"
                    + "import os  # an import\n" + bicycle.read_text())
    bicycle.unlink()  # its code moved into rules.py
    assert code_version.__wrapped__(package) != ""
    assert rules_version.__wrapped__(package) == rules
    step.write_text(step.read_text().replace("0.5", "0.25", 1))
    assert rules_version.__wrapped__(package) != rules


def test_numbas_cache_follows_the_users_cache_folder(tmp_path):
    """numba's kernels lie in the project's cache folder, which ``XDG_CACHE_HOME`` moves (and
    ``NUMBA_CACHE_DIR``, when set, overrides)."""
    import os
    import subprocess
    import sys

    env = {k: v for k, v in os.environ.items()
           if k not in ("NUMBA_CACHE_DIR", "ENN_TRAFFIC_CACHE")}
    code = "import os, enn_traffic; print(os.environ['NUMBA_CACHE_DIR'])"
    folder = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                            env={**env, "XDG_CACHE_HOME": str(tmp_path)}, check=True).stdout
    assert folder.strip().startswith(str(tmp_path / "enn-traffic" / "numba-"))
    chosen = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                            env={**env, "NUMBA_CACHE_DIR": str(tmp_path / "mine")},
                            check=True).stdout
    assert chosen.strip() == str(tmp_path / "mine")


# What the rules' modules import that decides no result: messages, files, the cache (keyed by
# content), the saved controller, the generations table's columns, and the learning curve.
DECIDES_NOTHING = {"enn_traffic", "enn_traffic.core.errors", "enn_traffic.core.io",
                   "enn_traffic.core.progress", "enn_traffic.core.provenance",
                   "enn_traffic.core.cache", "enn_traffic.runs.controller",
                   "enn_traffic.runs.generations_csv", "enn_traffic.report.plots",
                   "enn_traffic.core.interrupts"}


def test_everything_the_rules_import_is_in_the_rules():
    """A module that a run's rules import (a constant frozen into a kernel, a table of names)
    moves the rules' digest when it changes: it is in ``RULES``, or listed here as deciding
    nothing."""
    from test_imports import imported, modules

    from enn_traffic.core.provenance import PACKAGE as package
    from enn_traffic.core.provenance import in_rules as rules_file

    def in_rules(module: str) -> bool:
        return rules_file(known[module].relative_to(package).as_posix())

    known = modules()
    outside = {target for module, path in known.items() if in_rules(module)
               for target in imported(module, path, known) if not in_rules(target)}
    assert outside <= DECIDES_NOTHING, sorted(outside - DECIDES_NOTHING)


def test_a_table_measured_again_says_when_and_at_which_commit_and_its_line_follows(
        tmp_path, root):
    """``reproduce._record_again``: summary.md lists the re-measurement with its commit, and
    its lines are those of the tables as they are now: a changed ``table3.csv`` changes the
    family's Table 3 line and no other."""
    import shutil

    import pandas as pd

    from enn_traffic.experiments.families import SUMO
    from enn_traffic.experiments.reproduce import _record_again

    paper = tmp_path / "paper"
    shutil.copytree(root / "results" / "paper", paper,
                    ignore=shutil.ignore_patterns("controllers", "*.png", "runs", "crowds"))
    before = (paper / "summary.md").read_text().splitlines()
    table3 = pd.read_csv(paper / "sumo" / "table3.csv")
    table3.loc[0, "winner_collisions_per_s"] = 0.25
    table3.to_csv(paper / "sumo" / "table3.csv", index=False)
    _record_again(paper, SUMO, "table3.csv, table4.csv", ("abcdef1234", "0123456789ab", 0.0),
                  "a test")
    after = (paper / "summary.md").read_text().splitlines()
    changed = [line for line in after if line not in before and line.startswith("- ")]
    assert len(changed) == 1 and changed[0].startswith("- sumo/table3: ")
    assert "strategy 1: 0.374 -> 0.250" in changed[0]
    assert any(line.startswith("| sumo/table3.csv, table4.csv (measured again: a test) | full "
                               "| abcdef1234 | 0123456789ab |") for line in after)


def test_old_kernel_folders_are_pruned_but_the_recent_ones(tmp_path):
    """A new kernels' version removes the folders of older versions but the three most recently
    used and any used within the hour (another checkout may be running them)."""
    import os
    import time

    from enn_traffic.core.cache import prune_kernel_folders

    now = time.time()
    ages_h = {"a": 100, "b": 50, "c": 40, "d": 30, "e": 20, "recent": 0.1}
    for name, hours in ages_h.items():
        folder = tmp_path / f"numba-{name}"
        (folder / "sub").mkdir(parents=True)
        for path in (folder / "sub", folder):
            os.utime(path, (now - hours * 3600, now - hours * 3600))
    os.utime(tmp_path / "numba-a" / "sub", (now, now))  # used now, through its subfolder
    (tmp_path / "grids").mkdir()
    removed = prune_kernel_folders(tmp_path / "numba-new")
    assert sorted(p.name for p in removed) == ["numba-b", "numba-c", "numba-d"]
    assert sorted(p.name for p in tmp_path.iterdir()) == [
        "grids", "numba-a", "numba-e", "numba-recent"]
    removed = prune_kernel_folders(tmp_path / "numba-new", keep=0)
    assert [p.name for p in removed] == ["numba-e"]  # a and recent were used within the hour
