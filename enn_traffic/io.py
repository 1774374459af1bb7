"""Atomic file writes: a crash never leaves a half-written result in place."""

from __future__ import annotations

import os
from collections.abc import Callable
from pathlib import Path
from typing import IO

import pandas as pd


def write_atomic(path: str | Path, write: Callable[[IO], None], binary: bool = False) -> None:
    """Write through ``write(handle)`` into a temporary file, then rename it over ``path``."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.tmp")
    with open(tmp, "wb" if binary else "w") as handle:
        write(handle)
        handle.flush()
        os.fsync(handle.fileno())
    os.replace(tmp, path)


def write_text(path: str | Path, text: str) -> None:
    write_atomic(path, lambda handle: handle.write(text))


def write_csv(path: str | Path, table: pd.DataFrame) -> None:
    write_atomic(path, lambda handle: table.to_csv(handle, index=False, float_format="%.6g"))
