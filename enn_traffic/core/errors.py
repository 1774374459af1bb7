"""The one error type that the command line turns into a clear message and exit status 2."""

from __future__ import annotations

from pathlib import Path


class InputError(Exception):
    """Bad user input: names the file and, where there is one, the key at fault."""

    def __init__(self, message: str, file: str | Path | None = None, key: str | None = None):
        self.message = message
        self.file = str(file) if file is not None else None
        self.key = key
        super().__init__(str(self))

    def __str__(self) -> str:
        where = ": ".join(part for part in (shown(self.file), self.key) if part)
        return f"{where}: {self.message}" if where else self.message


def shown(file: str | None) -> str | None:
    """A file as a message names it: relative to the working folder when inside it, so that a
    scenario reads the same whether a check ran before its path was resolved or after."""
    if file is None or not Path(file).is_absolute():
        return file
    try:
        return str(Path(file).relative_to(Path.cwd()))
    except (ValueError, OSError):
        return file
