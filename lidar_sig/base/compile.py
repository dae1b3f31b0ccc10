"""The first run compiles the numerical kernels (numba) and caches them; say so once.

numba keeps the compiled kernels beside the package (``__pycache__``) or, where the package is
installed read-only, in the user's cache folder (``$XDG_CACHE_HOME/numba``, else
``~/.cache/numba``), so only the first run after installing pays the half minute.
"""
from __future__ import annotations

import importlib
import sys
import threading
import warnings

_ANNOUNCED = False
# Background loads started (warm_up), by kind of run: one per kind and process.
_WARMING = {}
#: Kernels every run calls (module, function names): the voxel grid, the neighbour search and
#: saliency from eigenvalues (the radix sort of :mod:`lidar_sig.numerics.sorting`, for large
#: clouds only, and a tile's load, :mod:`lidar_sig.tiling._load`, are compiled at their first
#: call). The others are declared where they belong: a descriptor's and a strategy's on the
#: plugin (``kernels``), the search's for radius scales on the Scales, the area weights' in
#: :mod:`lidar_sig.numerics.neighbors`; a run gathers them (``Pipeline.kernels``). The functions they call
#: are compiled and cached with them.
COMMON = (("lidar_sig.numerics._voxels", ("nearest", "_sort_keys", "_voxel_runs")),
          ("lidar_sig.numerics.kernels", ("saliency_rows", "entropy_rows", "order_eigenvalues")))
# numba modules that build an error message when imported, which numba colours through colorama
# by setting sys.stderr and back; numba imports them at its first load of a cached kernel, so
# warm_up imports them in the caller's thread first, see there
_COLOURING_IMPORTS = ("numba.cpython.listobj",)


def _dispatchers(kernels):
    for module, names in kernels:
        mod = importlib.import_module(module)
        for name in names:
            yield getattr(mod, name)


def load_kernels(kernels=COMMON):
    """Import numba and the modules of ``kernels`` ((module, function names) pairs, those a run
    calls). A run does so before its first timed step (numba takes a good part of a second to
    import), so that the steps' timings are their own work; compiling, or loading from the
    cache, happens at a kernel's first call."""
    for _ in _dispatchers(kernels):
        pass


def warm_up(key, run, kernels):
    """Start ``run``, a tiny run through ``kernels``, those of a run of kind ``key`` (descriptor,
    strategy, kind of scales, weights), in a background thread (once per ``key`` and process),
    and return the thread: loading the kernels from the cache (mostly numba's first call;
    docs/performance.md) then overlaps the run's first numpy steps. None when a kernel is not cached: numba
    compiles in the run's own thread then. Numba sets ``sys.stderr`` and back each time it
    builds an error message (it colours them through colorama), thousands of times while it
    compiles; from a second thread that would undo a redirection of stderr the caller's thread
    made meanwhile (as a test or a notebook does). The caller joins the thread before it
    calls a kernel itself, so that two threads never run parallel kernels at once (numba's
    workqueue threading layer would abort). A failure is ignored: the run proper loads, and
    reports, whatever failed here."""
    thread = _WARMING.get(key)
    if thread is None:
        if kernels_cached(kernels) is not True:
            return None
        for module in _COLOURING_IMPORTS:  # the messages a load from the cache builds, here
            try:
                importlib.import_module(module)
            except ImportError:  # a numba without this module
                pass

        def quietly():
            try:
                run()
            except Exception:  # noqa: BLE001 - see the docstring
                pass

        thread = _WARMING[key] = threading.Thread(target=quietly, name="lidar-sig kernels", daemon=True)
        thread.start()
    return thread


def kernels_cached(kernels=COMMON):
    """True if every kernel of ``kernels`` ((module, function names) pairs, those a run calls)
    has a compiled version cached for its current source and this machine's processor, False if
    one will be compiled, None if that cannot be told (numba's cache layout is not public)."""
    try:
        return all(_cached_here(d) for d in _dispatchers(kernels))
    except Exception:  # a numba without this layout: do not guess
        return None


def _cached_here(dispatcher):
    # the cache index (emptied when the source changes) keys each version by its argument types
    # and the processor it was compiled for: a cache made on another machine does not count
    machine = dispatcher.targetctx.codegen().magic_tuple()
    return any(key[1] == machine for key in dispatcher._cache._cache_file._load_index())


#: What the first run after installing is told, once per process (how long the kernels take to
#: compile: docs/performance.md).
COMPILING = ("compiling the numerical kernels ({what}): about half a minute, once after installing; "
             "later runs load them from the cache")


def announce_compilation(enabled, kernels, what):
    """Say once per process, when ``kernels`` (those a run of ``what``, e.g. "c3dcm, multiscale,
    k-nearest, area weights", calls) are about to be compiled, that they are: a LidarSigWarning,
    which the command line prints as one note line on stderr, on a terminal or not (a script, a
    notebook or a GIS calling the command would otherwise wait in silence), and Python shows
    as a warning. Not when ``enabled`` is False (``--quiet``, or a worker process of a tiled
    run, whose main process says it)."""
    global _ANNOUNCED
    if _ANNOUNCED or enabled is False:
        return
    if kernels_cached(kernels) is False:
        from .errors import LidarSigWarning

        _ANNOUNCED = True
        warnings.warn(COMPILING.format(what=what), LidarSigWarning, stacklevel=_outside_level())


def _outside_level():
    """The ``stacklevel`` that makes a warning given by this function's caller point at the
    first frame outside the package: the user's call (``ls.Pipeline().run(...)``,
    ``ls.changes(...)``, ``ls.Catalog.build(...)``, a job ...), whichever public entry led
    there, rather than the library's own line."""
    frame, level = sys._getframe(1), 1
    while frame.f_back is not None and frame.f_globals.get("__name__", "").partition(".")[0] == "lidar_sig":
        frame, level = frame.f_back, level + 1
    return level
