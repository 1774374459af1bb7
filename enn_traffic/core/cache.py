"""Arrays computed once and kept on disk: a network's walls and wall grid (docs/sumo.md,
"Large networks").

An entry is named by a digest of everything it depends on (the input file's bytes, the
parameters, a version of the code that builds it), so a changed input or a new version is built
again and nothing is ever invalidated by hand. The folder is ``$ENN_TRAFFIC_CACHE``, else
``$XDG_CACHE_HOME/enn-traffic``, else ``~/.cache/enn-traffic``; deleting it costs only the time
to build its entries again. A folder that cannot be written is not an error: entries are then
built every time.
"""

from __future__ import annotations

import contextlib
import functools
import hashlib
import os
import sys
import tempfile
from collections.abc import Callable
from pathlib import Path

import numpy as np


def cache_folder() -> Path:
    """Where entries are kept (read from the environment at every call)."""
    if os.environ.get("ENN_TRAFFIC_CACHE"):
        return Path(os.environ["ENN_TRAFFIC_CACHE"])
    base = os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache"
    return Path(base) / "enn-traffic"


@functools.lru_cache(maxsize=16)
def writable_folder(preferred: Path, name: str) -> Path:
    """``preferred``, made if missing, where files can be written in it; else ``name`` in a
    folder of the user's own in the temporary folder (a read-only cache folder, or
    ``$ENN_TRAFFIC_CACHE`` naming a file, then costs work done again, never a failed run);
    else a new temporary folder. Asked once per process and folder; a folder other than
    ``preferred`` is said in one line on stderr (numba and SUMO read entries only from a
    folder they can write, so what ``preferred`` holds is not used)."""
    chosen = None
    for folder in (preferred, Path(tempfile.gettempdir()) / f"enn-traffic-{os.getuid()}" / name):
        try:
            folder.mkdir(parents=True, exist_ok=True)
        except OSError:
            continue
        if os.access(folder, os.W_OK | os.X_OK):
            chosen = folder
            break
    if chosen == preferred:
        return preferred
    chosen = chosen or Path(tempfile.mkdtemp(prefix=f"enn-traffic-{name}-"))
    print(f"enn-traffic: note: cannot write {preferred}; using {chosen} instead (set "
          "ENN_TRAFFIC_CACHE to a folder you can write)", file=sys.stderr)
    return chosen


def file_digest(path: Path) -> str:
    """SHA-256 of a file's bytes."""
    digest = hashlib.sha256()
    with open(path, "rb") as handle:
        for block in iter(lambda: handle.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def file_stamp(path: str | Path) -> tuple[int, int, int, int]:
    """What changes whenever a file's bytes do: its inode, size, modification and
    status-change times (a status-change time cannot be set back by hand, as a modification
    time can). A key for what is read once per process while the file stays unchanged."""
    stat = Path(path).stat()
    return stat.st_ino, stat.st_size, stat.st_mtime_ns, stat.st_ctime_ns


def content_digest(path: str | Path) -> str:
    """SHA-256 of a file's bytes, computed once per process while the file stays unchanged
    (:func:`file_stamp`)."""
    path = Path(path).resolve()
    return _digest(path, *file_stamp(path))


@functools.lru_cache(maxsize=256)
def _digest(path: Path, *stamp: int) -> str:
    return file_digest(path)


def key_of(*parts: object) -> str:
    """An entry's name from what it depends on: bytes as they are, anything else as text."""
    digest = hashlib.sha256()
    for part in parts:
        data = part if isinstance(part, bytes) else str(part).encode()
        digest.update(len(data).to_bytes(8, "little") + data)
    return digest.hexdigest()[:32]


def cached_arrays(kind: str, key: str, build: Callable[[], dict[str, np.ndarray]]
                  ) -> dict[str, np.ndarray]:
    """The arrays of entry ``key`` of ``kind``: loaded when kept, else built by ``build`` and
    kept (written whole or not at all, so concurrent processes never read half an entry). An
    entry that does not load whole (cut short, a flipped bit that fails the archive's CRC) is
    built again and replaced; a write that fails (a full or read-only disk) leaves no partial
    file."""
    path = cache_folder() / kind / f"{key}.npz"
    try:
        with np.load(path, allow_pickle=False) as stored:
            return {name: stored[name] for name in stored.files}
    except FileNotFoundError:
        pass
    except Exception:  # numpy and zipfile raise many types on a damaged file
        pass  # unreadable: build it again
    arrays = build()
    partial = None
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        handle, partial = tempfile.mkstemp(dir=path.parent, suffix=".partial.npz")
        with os.fdopen(handle, "wb") as file:
            np.savez(file, **arrays)
        os.replace(partial, path)
        partial = None
    except OSError:  # a read-only or full disk: the entry is simply not kept
        pass
    finally:  # also on Ctrl-C
        if partial is not None:
            with contextlib.suppress(OSError):
                os.unlink(partial)
    return arrays


def tolerate_damaged_kernels() -> None:
    """A compiled kernel's entry in numba's cache (its index or its data file) that does not
    load whole (cut short, a flipped byte, another file's bytes) reads as absent: the kernel
    compiles again and its entry is written anew, as the project's own entries are built
    again. numba itself reads an index of another version or source as absent, but a damaged
    file stopped the command with an unpickling traceback. A kernel whose entry cannot be
    written is not kept, and runs."""
    from numba.core import caching

    cache_file = caching.IndexDataCacheFile
    if getattr(cache_file, "tolerates_damage", False):
        return
    load_index, load_data = cache_file._load_index, cache_file._load_data

    def _load_index(self):
        try:
            return load_index(self)
        except Exception:  # whatever unpickling a damaged file raises
            return {}

    def _load_data(self, name):
        try:
            return load_data(self, name)
        except OSError:
            raise
        except Exception as exc:  # numba's load() reads an OSError as "no entry"
            raise OSError(f"damaged numba cache entry {name}") from exc

    cache_file._load_index, cache_file._load_data = _load_index, _load_data
    cache_file.tolerates_damage = True

    # A kernel that compiled but cannot be kept (a full disk, a file-size limit) still runs;
    # numba removes its partial file and lets the error through, which stopped the command.
    save_overload = caching.Cache.save_overload

    def _save_overload(self, sig, data):
        with contextlib.suppress(OSError):
            save_overload(self, sig, data)

    caching.Cache.save_overload = _save_overload


def prune_kernel_folders(current: Path, keep: int = 3, grace_s: float = 3600.0) -> list[Path]:
    """Removes the compiled kernels of older versions (``numba-*`` beside ``current``) but the
    ``keep`` most recently used, and any used in the last ``grace_s`` seconds (another checkout
    may be running them). Each edit of the kernels' sources starts a new folder of 2–25 MB;
    without this they pile up. Returns the folders removed; errors leave a folder in place."""
    import shutil
    import time

    def last_used(folder: Path) -> float:
        return max([folder.stat().st_mtime]
                   + [sub.stat().st_mtime for sub in folder.iterdir() if sub.is_dir()])

    others = []
    for folder in current.parent.glob("numba-*"):
        if folder == current or not folder.is_dir() or folder.is_symlink():
            continue
        try:
            others.append((last_used(folder), folder))
        except OSError:
            continue
    others.sort(reverse=True)
    removed = []
    for used, folder in others[keep:]:
        if time.time() - used > grace_s:
            shutil.rmtree(folder, ignore_errors=True)
            removed.append(folder)
    return removed
