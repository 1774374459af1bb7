"""enn-traffic: evolve neural-network driving controllers in SUMO traffic (Eraqi et al., 2016)."""

import os
import sys
from pathlib import Path

from enn_traffic.core.cache import (
    cache_folder,
    prune_kernel_folders,
    tolerate_damaged_kernels,
    writable_folder,
)
from enn_traffic.core.provenance import kernels_version
from enn_traffic.core.registry import MovedModules

__version__ = "0.1.0"

# The package's folders, its layers, lowest first: a module imports only from its own folder
# and the folders before it (tests/test_imports.py checks every import; docs/design.md,
# "Architecture", is rendered from this list and each folder's docstring).
LAYERS = ("core", "report", "roads", "config", "sumo", "sim", "learning", "envs", "runs",
          "experiments", "bench", "cli")


def _numba_cache_dir() -> str:
    """numba's on-disk cache checks only each function's own file, not the modules it calls;
    a cache folder per version of the kernels' sources (:func:`~enn_traffic.core.provenance.
    kernels_version`) keeps a stale kernel from running. It lies in the project's cache folder
    (:func:`~enn_traffic.core.cache.cache_folder`: ``$ENN_TRAFFIC_CACHE``, ``$XDG_CACHE_HOME``),
    or, where that cannot be written, in the temporary folder
    (:func:`~enn_traffic.core.cache.writable_folder`): numba would otherwise write its kernels
    beside the package's sources."""
    name = f"numba-{kernels_version()}"
    return str(writable_folder(cache_folder() / name, name))


if "NUMBA_CACHE_DIR" not in os.environ:
    _new = not (cache_folder() / f"numba-{kernels_version()}").is_dir()
    os.environ["NUMBA_CACHE_DIR"] = _numba_cache_dir()
    if _new:  # a new version: its kernels compile, the oldest folders go
        prune_kernel_folders(Path(os.environ["NUMBA_CACHE_DIR"]))
    if "numba" in sys.modules:  # imported first, it read its settings without ours
        sys.modules["numba"].config.CACHE_DIR = os.environ["NUMBA_CACHE_DIR"]
tolerate_damaged_kernels()
# numba's parallel loops run on OpenMP (libgomp), whose idle threads spin by default: beside
# other busy processes (pytest -n 2, a process pool, a second user) a parallel region then
# waits for a descheduled spinner, and two threads run slower than one. Idle threads
# that sleep cost little on a quiet machine (docs/bench.md, "Sharing the cores").
# Read once, when libgomp loads, so before any kernel runs; a user's own setting of either
# stands.
if "OMP_WAIT_POLICY" not in os.environ and "GOMP_SPINCOUNT" not in os.environ:
    os.environ["OMP_WAIT_POLICY"] = "PASSIVE"


def _utf8_ctype() -> None:
    """Python reads and writes paths as UTF-8 under a C or POSIX locale (its UTF-8 mode),
    while SUMO's readers take a path's bytes in the C library's locale: under ``LC_ALL=C`` a
    path holding "ü" reached SUMO as a file that does not exist. Where the two differ, this
    process and the SUMO tools it starts take the C.UTF-8 locale for characters (nothing else
    changes; a locale of another encoding, which Python then uses too, is left as it is)."""
    import locale

    if sys.getfilesystemencoding().lower().replace("-", "") != "utf8":
        return
    if locale.nl_langinfo(locale.CODESET).lower().replace("-", "") == "utf8":
        return
    try:
        locale.setlocale(locale.LC_CTYPE, "C.UTF-8")
    except locale.Error:  # no such locale here: paths of ASCII letters still work
        return
    os.environ["LC_CTYPE"] = "C.UTF-8"
    if os.environ.get("LC_ALL"):
        os.environ["LC_ALL"] = "C.UTF-8"


_utf8_ctype()

# Modules a user's code may import by their names before the package's folders became its
# layers: they import, with a DeprecationWarning, for one release.
MOVED = {
    "enn_traffic.scenario": "enn_traffic.config",
    "enn_traffic.shipped": "enn_traffic.config.shipped",
    "enn_traffic.keys": "enn_traffic.core.keys",
    "enn_traffic.neural": "enn_traffic.core.neural",
    "enn_traffic.worlds": "enn_traffic.sim.world",
    "enn_traffic.controller": "enn_traffic.runs.controller",
    "enn_traffic.runner": "enn_traffic.runs.run",
    "enn_traffic.deploy": "enn_traffic.runs.evaluate",
    "enn_traffic.baseline": tuple(f"enn_traffic.experiments.gradient_rl.{part}" for part in (
        "campaign", "protocol", "scoring", "runs", "policy", "stats")),
}
sys.meta_path.append(MovedModules(MOVED))
