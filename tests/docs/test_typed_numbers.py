"""Every number docs/results.md, the README and docs/bench.md state is rendered from the facts
or checked against them (docs/_generate/README.md): a number a template types in its own words
must be one the project's files declare — a scenario's setting, a facts file's value, the
paper's numbers, a constant the package names — or one of the few below, each with its
source. A measured number typed into a template fails here; render it from its table."""

import ast
import json
import math
import re
import tomllib
from pathlib import Path

import pytest

DOCUMENTS = ("README.md", "docs/results.md", "docs/bench.md")
# Typed numbers whose source is not a file of the project's facts, and why each may stand.
CITED = {
    2016: "the paper's year, in its citation",
    24.5: "half of the 49 m a spin window drives, in the worked example of the spin rule",
    11.5: "the largest circle the paper's spin rule lets through "
          "(tests/experiments/test_spin_rule.py drives it)",
    23: "the extent of that circle, twice its radius",
}
STEP_S = 0.1  # a step's seconds (the paper's 0.1 s): a cap or window in steps is stated in s



def _numbers(value, out: set) -> None:
    if isinstance(value, dict):
        for item in value.values():
            _numbers(item, out)
    elif isinstance(value, list | tuple):
        for item in value:
            _numbers(item, out)
    elif isinstance(value, int | float) and not isinstance(value, bool):
        out.add(float(value))


def declared(root: Path) -> set[float]:
    """The numbers the project's files declare: every shipped scenario's settings (and the
    widths its name gives), every facts file under results/, the constants (upper-case
    module-level names) of the package, the paper's numbers among them, and Python's version
    in pyproject.toml; each also as steps in seconds and as a variance's standard deviation."""
    found: set[float] = set()
    for path in (root / "scenarios").glob("*.toml"):
        _numbers(tomllib.loads(path.read_text()), found)
        found.update(float(n) for n in re.findall(r"\d+", path.stem))
    for path in (root / "results").glob("**/facts/*.json"):
        _numbers(json.loads(path.read_text()), found)
    for path in (root / "enn_traffic").rglob("*.py"):
        for node in ast.parse(path.read_text()).body:
            targets = (node.targets if isinstance(node, ast.Assign)
                       else [node.target] if isinstance(node, ast.AnnAssign) else [])
            if targets and node.value is not None and any(
                    isinstance(t, ast.Name) and t.id.isupper() for t in targets):
                _numbers([c.value for c in ast.walk(node.value) if isinstance(c, ast.Constant)],
                         found)
    python = tomllib.loads((root / "pyproject.toml").read_text())["project"]["requires-python"]
    found.update(float(v) for v in re.findall(r"\d+\.\d+", python))
    return found | {v * STEP_S for v in found} | {math.sqrt(v) for v in found if v > 0}


def is_declared(written: str, known: set[float]) -> bool:
    """Is the number ``written`` (``4,321.5``) one of ``known``, rounded as it is written?"""
    number = float(written.replace(",", ""))
    digits = len(written.partition(".")[2])
    return any(round(value, digits) == number for value in known)


@pytest.mark.parametrize("document", DOCUMENTS)
def test_every_typed_number_is_declared_or_cited(render, root, document):
    known = declared(root) | {float(n) for n in CITED}
    typed = render.typed_numbers(root, document)
    assert typed, "the check found no typed number: it has stopped reading the template"
    undeclared = sorted({f"{written}: {line}" for written, line in typed
                         if not is_declared(written, known)})
    assert not undeclared, ("typed in the template, held by no file (render it from its "
                            "table or facts):\n" + "\n".join(undeclared))


def test_a_measured_number_typed_into_a_template_is_caught(render, root, tmp_path):
    """The check's own test: 4,321.5 steps typed into the README's template is found."""
    import shutil

    generate, copy = render.HERE, tmp_path / "_generate"
    shutil.copytree(generate, copy)
    template = copy / "templates" / "README.md.j2"
    template.write_text(template.read_text() + "\nThe best lived 4,321.5 steps.\n")
    try:
        render.HERE = copy
        typed = render.typed_numbers(root, "README.md")
    finally:
        render.HERE = generate
    assert ("4,321.5", "The best lived 4,321.5 steps.") in typed
    assert not is_declared("4,321.5", declared(root))
