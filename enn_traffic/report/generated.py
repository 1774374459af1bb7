"""Sections of a markdown document written from committed tables rather than typed
(docs/results.md by :mod:`enn_traffic.experiments.results_doc`, docs/bench.md by
:mod:`enn_traffic.report.bench_doc`): each lies between its markers, ``<!-- generated: NAME
-->`` and ``<!-- end generated: NAME -->``, and is made by a function of the tables' folder.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

Sections = dict[str, Callable[[Path], str]]


def markers(name: str) -> tuple[str, str]:
    return f"<!-- generated: {name} -->", f"<!-- end generated: {name} -->"


def section(name: str, folder: Path, sections: Sections) -> str:
    """Section ``name`` of ``sections`` with its markers, from the tables in ``folder``."""
    begin, end = markers(name)
    return f"{begin}\n{sections[name](folder)}\n{end}"


def rewrite(doc: Path, folder: Path, sections: Sections) -> None:
    """Replace every section of ``sections`` in ``doc``."""
    text = doc.read_text()
    for name in sections:
        begin, end = markers(name)
        start, stop = text.index(begin), text.index(end) + len(end)
        text = text[:start] + section(name, folder, sections) + text[stop:]
    doc.write_text(text)
