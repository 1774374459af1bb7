"""The project's documents, rendered from templates over facts (docs/_generate/README.md).

    python docs/_generate/render.py           # write every document
    python docs/_generate/render.py --check   # exit 1, with a diff, where a document differs

Each document is one Jinja2 template (``templates/``, undefined names an error) filled from
the context of its module in ``contexts/``: what the experiments wrote (CSV tables and small
JSON files of facts under ``results/``) and what the package declares (the scenario schema,
the registries, the key ledger). Nothing here simulates, draws, or reads a road network: a
number a document states is a number a file holds.
"""

from __future__ import annotations

import argparse
import difflib
import re
import sys
from pathlib import Path

import jinja2

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]
if str(HERE) not in sys.path:
    sys.path.insert(0, str(HERE))

import filters  # noqa: E402  (docs/_generate is a folder of scripts, not a package)
from contexts import DOCUMENTS  # noqa: E402


def environment() -> jinja2.Environment:
    """The templates' environment: an undefined name is an error, block tags leave no blank
    line behind, and the filters of :mod:`filters`."""
    env = jinja2.Environment(loader=jinja2.FileSystemLoader(HERE / "templates"),
                             undefined=jinja2.StrictUndefined, keep_trailing_newline=True,
                             trim_blocks=True, lstrip_blocks=True, autoescape=False)
    env.filters.update(filters.FILTERS)
    env.globals.update(filters.GLOBALS)
    return env


def context(root: Path, parts: tuple) -> dict:
    """The merged context of a document's parts (a name two parts give is an error), and
    ``table(PATH)``: the rows of ``results/PATH``, a CSV table, for a template that shows one
    as it is."""
    import pandas as pd

    def table(path: str) -> list[dict]:
        return pd.read_csv(root / "results" / path).to_dict("records")

    merged: dict = {"table": table}
    for part in parts:
        values = part.context(root)
        shared = merged.keys() & values.keys()
        if shared:
            raise ValueError(f"{part.__name__} gives {sorted(shared)} that another part gives")
        merged |= values
    return merged


NOTE = ("<!-- Rendered from docs/_generate/templates/{template} by "
        "python docs/_generate/render.py: edit the template, not this file. -->\n")


def render(root: Path = ROOT, only: list[str] | None = None) -> dict[str, str]:
    """Every document (or those ``only`` names, by their path) as its template renders it,
    under a line that says so."""
    env = environment()
    return {path: NOTE.format(template=template)
            + env.get_template(template).render(**context(root, parts))
            for path, (template, parts) in DOCUMENTS.items()
            if only is None or path in only}


def differences(root: Path = ROOT, only: list[str] | None = None) -> dict[str, str]:
    """Each document whose file differs from its rendering, with a unified diff."""
    found = {}
    for path, text in render(root, only).items():
        file = root / path
        written = file.read_text(encoding="utf-8") if file.is_file() else ""
        if written != text:
            found[path] = "".join(difflib.unified_diff(
                written.splitlines(keepends=True), text.splitlines(keepends=True),
                f"{path} (as written)", f"{path} (as rendered)"))
    return found


# What the typed-number check leaves aside: where a digit names something rather than states a
# quantity (a code span or block, a link's target, a commit, a file, the paper's sections,
# figures and tables, an issue, a strategy), and the mark an expression leaves (FILLED).
FILLED = "\x00"
NAMES = [re.compile(pattern, flags) for pattern, flags in (
    (r"^```.*?^```", re.S | re.M), (r"`[^`\n]*`", 0), (r"\]\([^)]*\)", 0),
    (r"\b[0-9a-f]{7}\b", 0), (r"[\w/.-]*\d[\w/-]*\.(?:csv|png|json|md|toml|npz|gif|xml)\b", 0),
    (r"(?:§|Figs?\.|Tables?|[Ii]ssues?|strateg(?:y|ies)|[Ii]teration|#)\s*"
     r"\d+(?:\.\d+)*(?:(?:[–-]|, | and | or )\d+(?:\.\d+)*)*", 0))]
NUMBER = re.compile(r"(?<![\w.\x00])\d+(?:[.,]\d+)*(?![\w\x00])")


def typed_numbers(root: Path, path: str) -> list[tuple[str, str]]:
    """The numbers document ``path``'s template states in its own words, not from the facts
    it is rendered over: each as written, with the line it stands in; every expression's
    output is left out, and so are digits that name rather than count (:data:`NAMES`)."""
    env = environment()
    env.finalize = lambda value: FILLED
    template, parts = DOCUMENTS[path]
    text = env.get_template(template).render(**context(root, parts))
    for pattern in NAMES:
        text = pattern.sub(" ", text)
    return [(match.group(), line.strip())
            for line in text.splitlines() for match in NUMBER.finditer(line)]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--check", action="store_true",
                        help="write nothing; exit 1 where a document differs from its rendering")
    parser.add_argument("documents", nargs="*", help="only these (paths from the repository root)")
    args = parser.parse_args(argv)
    if args.check:
        found = differences(ROOT, args.documents or None)
        for path, diff in found.items():
            print(f"{path} differs from its template: edit docs/_generate/templates/"
                  f"{DOCUMENTS[path][0]} and run python docs/_generate/render.py\n{diff}")
        return 1 if found else 0
    for path, text in render(ROOT, args.documents or None).items():
        (ROOT / path).write_text(text, encoding="utf-8")
        print(f"wrote {path}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
