"""Context part: navigation (docs/_generate/README.md). Its names are this part's own:
the parts of a document are merged, and a name two parts give is an error."""

from __future__ import annotations

from pathlib import Path


def context(root: Path) -> dict:
    return {}
