"""Which code made a result (docs/design.md, "Results and code"): digests of the package's
code, and the git commit of the checkout, recorded with each experiment of ``reproduce``.

Two digests: :func:`code_version` of every source, the record of which code wrote an output;
:func:`rules_version` of the sources that decide what a GA run computes, part of every run's
fingerprint, so that a run is made again when its rules change and reused when only a report,
the command line or the documentation did. Both digest the code, not the files that hold it
(:func:`source_digest`): a comment, a docstring, an import or a move of code from one file to
another leaves them as they were."""

from __future__ import annotations

import ast
import hashlib
import inspect
import subprocess
from collections.abc import Iterable
from functools import cache
from pathlib import Path

PACKAGE = Path(__file__).resolve().parents[1]

# What decides a GA run's result: the step rules and worlds, the GA and its loop, the traffic,
# the roads' walls, lane keeping, the network, the geometry, the keys that draw traffic, the
# strategies' driver kinds, and the scenario schema that resolves a scenario file into
# settings (tests/core/test_provenance.py checks that everything these import is here or named
# as deciding nothing).
RULES = ("sim", "learning", "sumo", "roads", "core/geometry.py", "core/neural.py",
         "core/keys.py", "core/registry.py", "config",
         "runs/run.py")


# Digests of earlier rules whose runs these rules continue: the code they digested computes
# what this code computes (tests/sim/test_behaviour.py's saved lives and the committed
# results' tests show it), only the digest moved; a run one made resumes, and its checkpoint
# then takes this digest. 72e67a1dafd1: the rules as the last version that digested the
# files' bytes and paths named them. 13c0276f6863: the rules before the sensor read further
# channels (a sensor of distances alone reads, and drives, as it did). ad197a53d028: the rules
# before the SUMO crowd's learners counted their 2-D conflicts and lanes split their edge's
# demand (every life is the same; a start_lane = "auto" resolves into the scenario's
# fingerprint, so a start it moves is another run). The rest: the rules of issues 82 and 83
# on SUMO's readers and crowd, commit by commit (the cap on learners raised to 3,000, the XML
# readers fed in blocks, the learners' SSM device set by their vehicle type and only where the
# start writes SSM, re-entries in one compiled call that remembers the lane spots the walls
# leave free, a failed crowd start ending its SUMO): every crowd, traced, and every test's
# life the same. e71d2599ee48: the rules before a sensor of distances alone compiled without
# the channels' work (its readings the same, bit for bit). 33063551da61: the rules before a
# scenario naming a folder that is not UTF-8 text was refused (every run the same).
# 2d253fbf0a4d: the rules before a population's memory limit was judged on the resolved
# scenario, at the run, not at loading (every run the same). d9efc5897251: the rules before
# that key was found by walking the scenario (the same). e028ae11880c: the rules before the
# channel helpers kept one body per type (the same compiled code).
SAME_RULES = ("72e67a1dafd1", "13c0276f6863", "ad197a53d028",
              "6b6259b1fa90", "ca0cd856c646", "b8dc5d7b1b60", "c6b06d6a604f", "fd611642ca7f",
              "935db775f49b", "da99c7326da3", "abb36c8bd1ce", "1a96cbd6b58d", "d1d4ccb609c7",
              "a7b125e5a324", "03de6bb5eb98", "3d3ea4d5b7fd", "961c1f8cd0b2", "852aaf9ed580",
              "e71d2599ee48", "33063551da61", "2d253fbf0a4d",
              "d9efc5897251", "e028ae11880c")


def source_digest(paths: Iterable[Path]) -> str:
    """A digest (12 hex digits) of the code in the Python files ``paths``: the syntax tree of
    every top-level statement without its docstrings and imports, in sorted order. Neither the
    files' names nor the order of their statements count, so moving a function into another
    file, renaming a module or editing a comment or docstring keeps the digest; any change of
    what a statement computes moves it."""
    statements = sorted(dump for path in set(paths) for dump in _statements(path))
    digest = hashlib.sha256()
    for dump in statements:
        digest.update(dump.encode() + b"\0")
    return digest.hexdigest()[:12]


def _statements(path: Path) -> list[str]:
    """Each top-level statement of ``path`` as the text of its syntax tree, docstrings and
    imports taken out at every depth (:func:`_inert`; a body left empty stays empty: the text
    need not be valid Python, only the same for the same code)."""
    tree = ast.parse(path.read_bytes(), filename=str(path))
    for node in ast.walk(tree):
        for field in ("body", "orelse", "finalbody"):
            body = getattr(node, field, None)
            if isinstance(body, list):
                setattr(node, field, [child for child in body if not _inert(child)])
    return [_text(statement) for statement in tree.body]


def _inert(statement: ast.stmt) -> bool:
    """An import, or a constant standing alone (a docstring): nothing a digest of the code
    needs."""
    return (isinstance(statement, ast.Import | ast.ImportFrom)
            or isinstance(statement, ast.Expr) and isinstance(statement.value, ast.Constant))


def _text(node: object) -> str:
    """A syntax tree as text, without positions and without fields that are None or empty
    (as Python 3.13's ``ast.dump`` writes it), so that a field a newer Python adds empty
    (``type_params``) leaves the text of older code as it was."""
    if isinstance(node, list):
        return "[" + ", ".join(map(_text, node)) + "]"
    if not isinstance(node, ast.AST):
        return repr(node)
    fields = [f"{name}={_text(value)}" for name in node._fields
              if (value := getattr(node, name, None)) is not None and value != []]
    return f"{type(node).__name__}({', '.join(fields)})"


@cache
def code_version(root: Path = PACKAGE) -> str:
    """A digest of every Python source of the package."""
    return source_digest(root.rglob("*.py"))


@cache
def rules_version(root: Path = PACKAGE) -> str:
    """A digest of the sources that decide a GA run's result (:data:`RULES`)."""
    paths: list[Path] = []
    for part in RULES:
        path = root / part
        paths += sorted(path.rglob("*.py")) if path.is_dir() else [path]
    return source_digest(paths)


@cache
def kernels_version(root: Path = PACKAGE) -> str:
    """A digest of what numba compiles from: the rules' sources (:data:`RULES`, whose
    constants kernels freeze in) and every module that defines a kernel. An edit to a report,
    an experiment or the command line leaves the compiled kernels valid. Read at every start
    of the package, so it digests the files' bytes and names (1 ms, where parsing them takes
    0.1 s): a comment edit or a move there compiles the kernels once more."""
    paths = {root / part for part in RULES if not (root / part).is_dir()}
    for part in RULES:
        if (root / part).is_dir():
            paths.update((root / part).rglob("*.py"))
    paths.update(path for path in root.rglob("*.py") if "@njit" in path.read_text(encoding="utf-8"))
    digest = hashlib.sha256()
    for path in sorted(paths):
        digest.update(path.relative_to(root).as_posix().encode() + b"\0")
        digest.update(path.read_bytes())
    return digest.hexdigest()[:12]


def in_rules(relative: str) -> bool:
    """Is the package file ``relative`` (``sim/arena.py``) one of the rules' sources?"""
    return any(relative == part or relative.startswith(part + "/") for part in RULES)


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
        if not in_rules(path.relative_to(PACKAGE).as_posix()):
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
