"""The context of the document bench renders (docs/_generate/README.md)."""

from __future__ import annotations

from pathlib import Path


def context(root: Path) -> dict:
    return {}
