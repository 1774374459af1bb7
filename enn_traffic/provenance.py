"""Which code made a result (docs/design.md, "Results and code"): digests of the package's
sources, and the git commit of the checkout, recorded with each experiment of ``reproduce``.

Two digests: :func:`code_version` of every source, the record of which code wrote an output;
:func:`rules_version` of the sources that decide what a GA run computes, part of every run's
fingerprint, so that a run is made again when its rules change and reused when only a report,
the command line or the documentation did."""

from __future__ import annotations

import hashlib
import inspect
import subprocess
from collections.abc import Iterable
from functools import cache
from pathlib import Path

PACKAGE = Path(__file__).resolve().parent

# What decides a GA run's result: the step rules and worlds, the GA and its loop, the traffic,
# the roads' walls, lane keeping, the network, the geometry, the keys that draw traffic, the
# strategies' driver kinds, and the scenario schema that resolves a scenario file into
# settings (tests/test_provenance.py checks that everything these import is here or named
# as deciding nothing).
RULES = ("sim", "evolution", "traffic", "roads", "lanekeeping", "geometry.py", "neural.py",
         "worlds.py", "keys.py", "kinds.py", "scenario.py", "runner.py")


def source_digest(paths: Iterable[Path], root: Path = PACKAGE) -> str:
    """A digest (12 hex digits) of the Python files ``paths`` under ``root``: their names
    relative to it and their bytes, in sorted order."""
    digest = hashlib.sha256()
    for path in sorted(paths):
        digest.update(path.relative_to(root).as_posix().encode() + b"\0")
        digest.update(path.read_bytes())
    return digest.hexdigest()[:12]


@cache
def code_version(root: Path = PACKAGE) -> str:
    """A digest of every Python source of the package."""
    return source_digest(root.rglob("*.py"), root)


@cache
def rules_version(root: Path = PACKAGE) -> str:
    """A digest of the sources that decide a GA run's result (:data:`RULES`)."""
    paths: list[Path] = []
    for part in RULES:
        path = root / part
        paths += sorted(path.rglob("*.py")) if path.is_dir() else [path]
    return source_digest(paths, root)


@cache
def kernels_version(root: Path = PACKAGE) -> str:
    """A digest of what numba compiles from: the rules' sources (:data:`RULES`, whose
    constants kernels freeze in) and every module that defines a kernel. An edit to a report,
    an experiment or the command line leaves the compiled kernels valid."""
    paths = {root / part for part in RULES if not (root / part).is_dir()}
    for part in RULES:
        if (root / part).is_dir():
            paths.update((root / part).rglob("*.py"))
    paths.update(path for path in root.rglob("*.py") if "@njit" in path.read_text())
    return source_digest(paths, root)


def sources_of(*deciders: object) -> str:
    """A digest of the files that define ``deciders`` (an evaluator's class, a stopping
    rule) outside :data:`RULES`, which a run's fingerprint takes in too: empty when they all
    lie within the rules, every source's when one has no file in the package."""
    paths = set()
    for decider in deciders:
        decider = getattr(decider, "func", decider)  # functools.partial
        try:
            path = Path(inspect.getsourcefile(decider if inspect.isroutine(decider)
                                              or inspect.isclass(decider) else type(decider)))
        except TypeError:
            return code_version()
        path = path.resolve()
        if not path.is_relative_to(PACKAGE):
            return code_version()
        if path.relative_to(PACKAGE).parts[0] not in RULES:
            paths.add(path)
    return source_digest(paths) if paths else ""


def commit() -> str | None:
    """The git commit of the checkout the package runs from, with ``+changes`` when tracked
    files differ from it; None outside a git checkout."""
    def git(*args: str) -> subprocess.CompletedProcess:
        return subprocess.run(["git", "-C", str(PACKAGE), *args], capture_output=True,
                              text=True, timeout=30)

    try:
        head = git("rev-parse", "--short=10", "HEAD")
        if head.returncode != 0:
            return None
        changed = git("status", "--porcelain", "--untracked-files=no").stdout.strip()
    except (OSError, subprocess.SubprocessError):
        return None
    return head.stdout.strip() + ("+changes" if changed else "")
