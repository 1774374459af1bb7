"""Input files checked before they are opened (regular files of bounded size); output files and
folders checked before any work, written whole or not at all, and a run folder or an output
file locked while a command writes it (docs/design.md, "Reliability")."""

from __future__ import annotations

import contextlib
import errno
import fcntl
import functools
import gzip
import math
import os
import stat
import tempfile
import zlib
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import IO

import pandas as pd

from enn_traffic.core.errors import InputError

MAX_INPUT_MB_VARIABLE = "ENN_TRAFFIC_MAX_INPUT_MB"
DEFAULT_MAX_INPUT_MB = 4096  # far above any published SUMO city's network or demand
GZIP_RATIO = 100  # a gzip input that inflates more than this much (past 64 MB) is refused

_KINDS = ((stat.S_ISDIR, "a folder"), (stat.S_ISFIFO, "a pipe"), (stat.S_ISCHR, "a device"),
          (stat.S_ISBLK, "a device"), (stat.S_ISSOCK, "a socket"))


def max_input_bytes() -> int:
    """The largest input file, and the most a gzip input may inflate to:
    ``$ENN_TRAFFIC_MAX_INPUT_MB`` megabytes (4,096 by default)."""
    text = os.environ.get(MAX_INPUT_MB_VARIABLE) or str(DEFAULT_MAX_INPUT_MB)
    try:
        megabytes = float(text)
    except ValueError:
        megabytes = math.nan
    if not (math.isfinite(megabytes) and megabytes > 0):
        raise InputError(f"{MAX_INPUT_MB_VARIABLE}={text!r}: expected a number of megabytes "
                         "above 0")
    return int(megabytes * 2**20)


def check_input_file(path: str | Path, what: str = "file", source: str | Path | None = None,
                     key: str | None = None) -> None:
    """Refuse, before anything opens it, an input that is missing, not a regular file (a
    folder, a pipe that would block the read, a device such as ``/dev/zero`` that never
    ends, a socket), larger than :func:`max_input_bytes`, or a gzip file that inflates past
    that or by more than ``GZIP_RATIO`` times (a compressed bomb). The error names ``source``
    and ``key`` where the path was given (a scenario's key, an including file), else the
    path itself."""
    path = Path(path)
    where = (source, key) if source is not None else (path, key)
    named = f": {path}" if source is not None else ""
    try:
        status = os.stat(path)
    except FileNotFoundError:
        raise InputError(f"{what} not found{named}", *where) from None
    except OSError as exc:
        raise InputError(f"{what} cannot be read{named}: {exc.strerror or exc}", *where) \
            from None
    for test, kind in _KINDS:
        if test(status.st_mode):
            raise InputError(f"{what} is {kind}, not a file{named}", *where)
    limit = max_input_bytes()
    if status.st_size > limit:
        raise InputError(f"{what} is {_size(status.st_size)}, more than the "
                         f"{_size(limit)} an input may be ({MAX_INPUT_MB_VARIABLE}){named}",
                         *where)
    if path.name.endswith(".gz"):
        problem = gzip_problem(path, limit, status.st_ino, status.st_size, status.st_mtime_ns)
        if problem:
            raise InputError(f"{what} {problem}{named}", *where)


def _size(size: int) -> str:
    """A file size in MB, or in bytes below 1 MB (a limit below a megabyte said as 0 MB)."""
    return f"{size / 2**20:,.0f} MB" if size >= 2**20 else f"{size:,} bytes"


def inflation_problem(inflated: int, packed: int, limit: int) -> str | None:
    """Why data of ``packed`` bytes that inflates to ``inflated`` may not be read: past the
    input limit, or more than ``GZIP_RATIO`` times past 64 MB (a compressed bomb)."""
    if inflated > limit:
        return f"inflates past the {_size(limit)} an input may be ({MAX_INPUT_MB_VARIABLE})"
    if inflated > 64 * 2**20 and inflated > GZIP_RATIO * max(packed, 1):
        return (f"inflates more than {GZIP_RATIO} times ({packed:,} bytes to over "
                f"{inflated:,}): a compressed bomb")
    return None


@functools.lru_cache(maxsize=256)
def gzip_problem(path: Path, limit: int, *stamp: int) -> str | None:
    """Why the gzip file ``path`` (of stamp ``(inode, size, ...)``) may not be read, or None:
    not whole (cut short, a CRC that fails), or inflating as :func:`inflation_problem`
    refuses; by inflating it up to ``limit`` bytes, once per process while it is unchanged."""
    inflated = 0
    try:
        with gzip.open(path, "rb") as handle:
            for block in iter(lambda: handle.read(1 << 20), b""):
                inflated += len(block)
                problem = inflation_problem(inflated, stamp[1], limit)
                if problem:
                    return problem
    except (OSError, EOFError, zlib.error) as exc:
        return f"is not a whole gzip file ({exc})"
    return None


def write_atomic(path: str | Path, write: Callable[[IO], None], binary: bool = False) -> None:
    """Write through ``write(handle)`` into a temporary file, then rename it over ``path``. A
    write that fails (a full disk, a folder that cannot be written) leaves ``path`` as it was,
    removes the temporary file, and is an InputError naming ``path``."""
    path = Path(path)
    tmp = path.with_name(f".{path.name}.tmp")
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        with (open(tmp, "wb") if binary else open(tmp, "w", encoding="utf-8")) as handle:
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
    if source is not None and _same_file(written, source):
        raise InputError(f"is the scenario's own folder: the command would write its copy of "
                         f"the scenario over {written.name}; give another --out",
                         written.parent, "--out")


def check_not_input(written: str | Path, inputs: list, key: str = "--out") -> None:
    """Refuse an output path that is one of the files the command reads (a scenario named
    ``.png`` given as ``render``'s ``--out``): writing it would replace the user's file."""
    if any(_same_file(written, source) for source in inputs):
        raise InputError("is a file the command reads: writing it would replace it; give "
                         "another file", written, key)


def _same_file(one: str | Path, other: str | Path) -> bool:
    """Do both paths exist and name the same file (through links too)?"""
    try:
        return os.path.samefile(one, other)
    except OSError:
        return False


def check_output_folder(path: str | Path) -> None:
    """Could a command write its files into the folder ``path`` (made if missing; its
    ``--out``)?"""
    path = Path(path)
    if path.exists() and not path.is_dir():
        raise InputError("is a file, not a folder", path, "--out")
    _writable(path, path, "--out")


_held: dict[Path, tuple[int, int]] = {}  # locked folder: (descriptor, times entered)


def _holder(folder: Path) -> str:
    """The process that holds ``folder``'s lock, from the kernel's table of locks (Linux);
    "another process" where it cannot be told."""
    try:
        inode = folder.stat().st_ino
        for line in Path("/proc/locks").read_text(encoding="utf-8").splitlines():
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


@contextlib.contextmanager
def file_lock(path: str | Path) -> Iterator[None]:
    """Hold a lock on the output file ``path`` while the block runs, so that a second command
    writing the same file is refused (exit 2, naming the process) instead of one result
    silently replacing the other's. The lock is a hidden file beside it, ``.NAME.lock``,
    removed at the end."""
    path = Path(path).resolve()
    lock = path.with_name(f".{path.name}.lock")
    while True:
        try:
            path.parent.mkdir(parents=True, exist_ok=True)
            descriptor = os.open(lock, os.O_RDWR | os.O_CREAT | os.O_NOFOLLOW, 0o644)
        except OSError as exc:
            raise InputError(f"cannot lock the file: {exc.strerror or exc}", path, "--out") \
                from None
        try:
            fcntl.flock(descriptor, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError as exc:
            os.close(descriptor)
            if exc.errno in (errno.EWOULDBLOCK, errno.EACCES):
                raise InputError(f"another command is writing this file ({_holder(lock)}); "
                                 "wait for it to end, or give another file", path, "--out") \
                    from None
            raise InputError(f"cannot lock the file: {exc.strerror}", path, "--out") from None
        try:  # the lock file its last holder removed between our open and our lock: again
            if os.fstat(descriptor).st_ino == os.stat(lock, follow_symlinks=False).st_ino:
                break
        except OSError:
            pass
        os.close(descriptor)
    try:
        yield
    finally:
        with contextlib.suppress(OSError):
            lock.unlink()
        os.close(descriptor)


SUMO_FOLDER_PREFIX = "enn-sumo-"  # a SUMO start's own folder (sumo.simulation.Simulation)


def process_folder() -> Path:
    """A new folder in the system's temporary folder, named ``enn-sumo-<pid>-...`` by the
    process that makes it, so that :func:`sweep_process_folders` can tell one whose process
    was killed before it could remove it."""
    return Path(tempfile.mkdtemp(prefix=f"{SUMO_FOLDER_PREFIX}{os.getpid()}-"))


def _ended(pid: int) -> bool:
    """Has process ``pid`` ended (gone, or a zombie not yet reaped)?"""
    try:
        state = Path(f"/proc/{pid}/stat").read_text(encoding="utf-8").rsplit(")", 1)[1].split()[0]
        return state in ("Z", "X")
    except (OSError, IndexError):  # no such process, or no /proc (not Linux)
        try:
            os.kill(pid, 0)
        except ProcessLookupError:
            return True
        except OSError:  # another user's
            return False
        return False


def sweep_process_folders(pid: int | None = None, wait_s: float = 0.0) -> list[Path]:
    """Remove this user's folders of :func:`process_folder` whose process has ended (a
    fresh process or worker killed on Ctrl-C, a SIGKILL); with ``pid``, that process's
    only, waiting up to ``wait_s`` seconds for it to end. Returns the folders removed."""
    import shutil
    import time

    base = Path(tempfile.gettempdir())
    prefix = SUMO_FOLDER_PREFIX
    pattern = f"{prefix}{pid}-*" if pid is not None else f"{prefix}*-*"
    deadline = time.monotonic() + wait_s
    while pid is not None and not _ended(pid) and time.monotonic() < deadline:
        time.sleep(0.01)
    removed = []
    for folder in base.glob(pattern):
        owner = folder.name[len(prefix):].split("-", 1)[0]
        try:
            mine = folder.is_dir() and not folder.is_symlink() and \
                folder.stat().st_uid == os.getuid()
        except OSError:
            continue
        if owner.isdigit() and mine and int(owner) != os.getpid() and _ended(int(owner)):
            shutil.rmtree(folder, ignore_errors=True)
            removed.append(folder)
    return removed
