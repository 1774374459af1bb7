"""The document renderer (docs/_generate, a folder of scripts, not a package) for the tests
of the documents."""

import importlib
import sys
from pathlib import Path

import pytest

GENERATE = Path(__file__).resolve().parents[2] / "docs" / "_generate"


@pytest.fixture(scope="module")
def render():
    """docs/_generate/render.py as a module (its contexts importable while a test runs)."""
    sys.path.insert(0, str(GENERATE))
    try:
        yield importlib.import_module("render")
    finally:
        sys.path.remove(str(GENERATE))
