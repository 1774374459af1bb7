from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture
def root() -> Path:
    return ROOT


def write_scenario(path: Path, text: str) -> Path:
    path.write_text(text)
    return path
