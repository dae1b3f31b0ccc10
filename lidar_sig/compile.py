"""The first run compiles the numerical kernels (numba) and caches them; say so once.

numba keeps the compiled kernels beside the package (``__pycache__``) or, where the package is
installed read-only, in the user's cache folder (``$XDG_CACHE_HOME/numba``, else
``~/.cache/numba``), so only the first run after installing pays the 15-20 s.
"""
from __future__ import annotations

import sys

_ANNOUNCED = False


def _dispatchers():
    from . import get, grid, kernels, saliency

    for module in (grid, kernels, saliency, get):
        for value in vars(module).values():
            # inlined helpers are compiled into their callers and have no cache of their own
            if hasattr(value, "_cache") and value.targetoptions.get("inline") != "always":
                yield value


def kernels_cached():
    """True if every kernel has a compiled version cached for its current source, False if one
    will be compiled, None if that cannot be told (numba's cache layout is not public)."""
    try:
        return all(bool(d._cache._cache_file._load_index()) for d in _dispatchers())
    except Exception:  # a numba without this layout: do not guess
        return None


def announce_compilation(enabled=None):
    """Print once per process, on a terminal (or when ``enabled``), that the kernels are being
    compiled, when they are."""
    global _ANNOUNCED
    if _ANNOUNCED:
        return
    _ANNOUNCED = True
    if enabled is False or (enabled is None and not sys.stderr.isatty()):
        return
    if kernels_cached() is False:
        print("lidar-sig: compiling the numerical kernels: the first run after installing takes "
              "15-20 s more, later runs use the cache", file=sys.stderr, flush=True)
