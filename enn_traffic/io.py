"""Output files and folders: checked before any work, written whole or not at all, and a run
folder locked while a run writes it (docs/design.md, "Reliability")."""

from __future__ import annotations

import contextlib
import errno
import fcntl
import os
import tempfile
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import IO

import pandas as pd

from enn_traffic.errors import InputError


def write_atomic(path: str | Path, write: Callable[[IO], None], binary: bool = False) -> None:
    """Write through ``write(handle)`` into a temporary file, then rename it over ``path``. A
    write that fails (a full disk, a folder that cannot be written) leaves ``path`` as it was,
    removes the temporary file, and is an InputError naming ``path``."""
    path = Path(path)
    tmp = path.with_name(f".{path.name}.tmp")
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        with open(tmp, "wb" if binary else "w") as handle:
            write(handle)
            handle.flush()
            os.fsync(handle.fileno())
        os.replace(tmp, path)
    except OSError as exc:
        with contextlib.suppress(OSError):
            tmp.unlink()
        raise InputError(f"cannot write: {exc.strerror or exc}", path) from None
    except BaseException:  # Ctrl-C, SIGTERM: no temporary file left behind either
        with contextlib.suppress(OSError):
            tmp.unlink()
        raise


def write_text(path: str | Path, text: str) -> None:
    write_atomic(path, lambda handle: handle.write(text))


def write_csv(path: str | Path, table: pd.DataFrame) -> None:
    write_atomic(path, lambda handle: table.to_csv(handle, index=False, float_format="%.6g"))


def _writable(folder: Path, path: Path, key: str | None) -> None:
    """Can files be made in ``folder`` (or, while it does not exist, in the nearest folder
    above it, where it would be made)? Tried by making a temporary file there."""
    existing = folder
    while not existing.exists() and existing != existing.parent:
        if existing.is_symlink():  # a dangling link, or a loop of links
            raise InputError(f"{existing} is a broken symbolic link", path, key)
        existing = existing.parent
    if not existing.is_dir():
        raise InputError(f"{existing} is not a folder", path, key)
    try:
        tempfile.TemporaryFile(dir=existing).close()
    except OSError as exc:
        raise InputError(f"cannot write in {existing}: {exc.strerror or exc}", path, key) \
            from None


def check_output_file(path: str | Path, key: str | None = "--out",
                      suffixes: tuple[str, ...] = ()) -> None:
    """Could a command write the file ``path`` (one of ``suffixes``, when given)? Asked before
    any work, so that no result is computed and then lost."""
    path = Path(path)
    if suffixes and path.suffix.lower() not in suffixes:
        raise InputError(f"the file must end in {', '.join(suffixes)}", path, key)
    if path.is_symlink() and not path.exists():
        raise InputError("a broken symbolic link", path, key)
    if path.is_dir():
        raise InputError("is a folder; give a file name", path, key)
    if path.exists() and not path.is_file():
        raise InputError("is not a regular file (a device, a pipe ...)", path, key)
    _writable(path.parent, path, key)


def check_not_source(written: Path, source: str | Path | None) -> None:
    """Refuse a command whose own copy of its scenario, ``written`` (in its output folder),
    is the scenario file ``source`` it reads: it would write over the user's file, even with
    ``--force`` (docs/design.md, "Reliability")."""
    if source is not None and written.exists() and written.resolve() == Path(source).resolve():
        raise InputError(f"is the scenario's own folder: the command would write its copy of "
                         f"the scenario over {written.name}; give another --out",
                         written.parent, "--out")


def check_output_folder(path: str | Path, key: str | None = "--out") -> None:
    """Could a command write its files into the folder ``path`` (made if missing)?"""
    path = Path(path)
    if path.exists() and not path.is_dir():
        raise InputError("is a file, not a folder", path, key)
    _writable(path, path, key)


_held: dict[Path, tuple[int, int]] = {}  # locked folder: (descriptor, times entered)


def _holder(folder: Path) -> str:
    """The process that holds ``folder``'s lock, from the kernel's table of locks (Linux);
    "another process" where it cannot be told."""
    try:
        inode = folder.stat().st_ino
        for line in Path("/proc/locks").read_text().splitlines():
            fields = line.split()  # "1: FLOCK ADVISORY WRITE <pid> <dev>:<inode> 0 EOF"
            at = fields.index("FLOCK") if "FLOCK" in fields else -1
            if at >= 0 and "->" not in fields and fields[at + 4].endswith(f":{inode}"):
                return f"process {fields[at + 3]}"
    except (OSError, IndexError):
        pass
    return "another process"


def _busy(folder: Path) -> InputError:
    return InputError(f"another run is writing this folder ({_holder(folder)}); wait for it "
                      "to end, or use another --out", folder)


def check_unlocked(folder: str | Path) -> None:
    """Is ``folder`` free of a run that writes it? Asked before any work, without writing
    anything: :func:`folder_lock` takes the lock itself."""
    folder = Path(folder).resolve()
    if folder in _held:
        return
    try:
        descriptor = os.open(folder, os.O_RDONLY | os.O_DIRECTORY)
    except OSError:
        return  # no folder yet: no run writes it
    try:
        fcntl.flock(descriptor, fcntl.LOCK_SH | fcntl.LOCK_NB)
    except OSError:
        raise _busy(folder) from None
    finally:
        os.close(descriptor)


@contextlib.contextmanager
def folder_lock(folder: str | Path) -> Iterator[None]:
    """Make ``folder`` and hold its lock while the block runs (a lock on the folder itself:
    no file is written). A second process that asks for it gets an InputError naming the
    process that holds it; taken again by its holder, it is simply held on."""
    folder = Path(folder).resolve()
    if folder in _held:
        descriptor, count = _held[folder]
        _held[folder] = (descriptor, count + 1)
    else:
        try:
            folder.mkdir(parents=True, exist_ok=True)
            descriptor = os.open(folder, os.O_RDONLY | os.O_DIRECTORY)
        except OSError as exc:
            raise InputError(f"cannot open the folder: {exc.strerror or exc}", folder) from None
        try:
            fcntl.flock(descriptor, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError as exc:
            os.close(descriptor)
            if exc.errno in (errno.EWOULDBLOCK, errno.EACCES):
                raise _busy(folder) from None
            raise InputError(f"cannot lock the folder: {exc.strerror}", folder) from None
        _held[folder] = (descriptor, 1)
    try:
        yield
    finally:
        descriptor, count = _held[folder]
        if count > 1:
            _held[folder] = (descriptor, count - 1)
        else:
            del _held[folder]
            os.close(descriptor)  # releases the lock
