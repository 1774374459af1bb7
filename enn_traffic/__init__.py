"""enn-traffic: evolve neural-network driving controllers in SUMO traffic (Eraqi et al., 2016)."""

import os

from enn_traffic.cache import cache_folder
from enn_traffic.provenance import kernels_version

__version__ = "0.1.0"


def _numba_cache_dir() -> str:
    """numba's on-disk cache checks only each function's own file, not the modules it calls;
    a cache folder per version of the kernels' sources (:func:`~enn_traffic.provenance.
    kernels_version`) keeps a stale kernel from running. It lies in the project's cache folder
    (:func:`~enn_traffic.cache.cache_folder`: ``$ENN_TRAFFIC_CACHE``, ``$XDG_CACHE_HOME``)."""
    return str(cache_folder() / f"numba-{kernels_version()}")


os.environ.setdefault("NUMBA_CACHE_DIR", _numba_cache_dir())
