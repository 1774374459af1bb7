"""The import graph runs one way (issue 23): each layer imports only from the layers below it."""

import ast
from pathlib import Path

PACKAGE = Path(__file__).resolve().parents[1] / "enn_traffic"

# What each part may not import (its own layer and those below are allowed).
FORBIDDEN = {
    "network": ["sim", "evolution", "experiments", "lanekeeping", "runner", "traffic", "roads"],
    "keys": ["sim", "evolution", "experiments", "lanekeeping", "runner"],
    "geometry": ["sim", "evolution", "experiments", "lanekeeping", "runner", "traffic", "roads"],
    "scenario": ["sim", "evolution", "experiments", "lanekeeping", "runner", "worlds"],
    "roads": ["sim", "evolution", "experiments", "lanekeeping", "runner", "worlds"],
    "traffic": ["sim", "evolution", "experiments", "lanekeeping", "runner", "worlds"],
    "sim": ["evolution", "experiments", "lanekeeping", "runner", "worlds", "deploy", "bench",
            "reproduce", "cli"],
    "evolution": ["experiments", "runner", "deploy", "bench", "reproduce", "cli"],
    "lanekeeping": ["experiments", "runner", "evolution", "deploy", "bench", "reproduce", "cli"],
    "generations": ["experiments", "runner", "evolution", "deploy", "bench", "reproduce",
                    "cli"],
    "runner": ["experiments", "deploy", "bench", "reproduce", "cli"],
    "experiments": ["bench", "reproduce", "cli"],
}


def _imports(path: Path) -> set[str]:
    """The enn_traffic parts (first name after ``enn_traffic.``) a module imports."""
    found = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom) and node.module:
            names = [node.module] + [f"{node.module}.{a.name}" for a in node.names]
        elif isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        else:
            continue
        for name in names:
            parts = name.split(".")
            if parts[0] == "enn_traffic" and len(parts) > 1:
                found.add(parts[1])
    return found


def test_no_import_runs_back_up():
    wrong = []
    for part, forbidden in FORBIDDEN.items():
        files = [PACKAGE / f"{part}.py"] if (PACKAGE / f"{part}.py").exists() else sorted(
            (PACKAGE / part).rglob("*.py"))
        assert files, part
        for path in files:
            for name in _imports(path) & set(forbidden):
                wrong.append(f"{path.relative_to(PACKAGE)} imports enn_traffic.{name}")
    assert not wrong, "\n".join(wrong)
