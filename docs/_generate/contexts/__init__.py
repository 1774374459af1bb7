"""What each document is rendered from: its template and the context parts it reads, each a
function ``context(root) -> dict`` of the files under ``root`` (the repository's root),
merged (a name two parts give is an error)."""

from __future__ import annotations

from contexts import (
    bench,
    comparison,
    crowds,
    design,
    navigation,
    readme,
    round2,
    scenarios,
    sumo,
    verdicts,
)

DOCUMENTS = {
    "README.md": ("README.md.j2", (navigation, crowds, bench, readme, verdicts)),
    "docs/results.md": ("results.md.j2", (navigation, crowds, comparison, round2, verdicts)),
    "docs/bench.md": ("bench.md.j2", (bench,)),
    "docs/sumo.md": ("sumo.md.j2", (sumo,)),
    "docs/scenarios.md": ("scenarios.md.j2", (scenarios,)),
    "docs/design.md": ("design.md.j2", (design,)),
    "docs/history.md": ("history.md.j2", (bench,)),
}
