"""The first run compiles the numerical kernels (numba) and caches them; say so once.

numba keeps the compiled kernels beside the package (``__pycache__``) or, where the package is
installed read-only, in the user's cache folder (``$XDG_CACHE_HOME/numba``, else
``~/.cache/numba``), so only the first run after installing pays the half minute.
"""
from __future__ import annotations

import importlib
import threading
import warnings

_ANNOUNCED = False
# Background loads started (warm_up), by kind of run: one per kind and process.
_WARMING = {}
# Kernels every run calls, those of each kind of scales, of each strategy and of each built-in
# descriptor (module, function names); the functions they call are compiled and cached with them.
_COMMON = (("grid", ("nearest",)), ("kernels", ("saliency_rows", "entropy_rows", "order_eigenvalues")))
# (k-nearest scales are counted by the search itself; count_ties, which counts the few rows the
# search leaves to a scan or the k-d tree, is loaded or compiled when a run first has such rows)
_KIND = {"knn": (), "radius": (("grid", ("count_within",)),)}
_STRATEGY = {"multiscale": (("kernels", ("mean_over_scales",)),)}
_WEIGHTS = {"area": (("grid", ("third_nearest",)),)}
_DESCRIPTOR = {
    "c3dcm": (("kernels", ("covariance_eigenvalues",)),),
    "t3dvt": (("kernels", ("voting_eigenvalues",)),),
    "t3dvt-get": (("kernels", ("voting_eigenvalues",)),
                  ("get", ("first_pass", "second_pass", "third_pass", "_pack_rows"))),
}
# numba modules that build an error message when imported, which numba colours through colorama
# by setting sys.stderr and back; numba imports them at its first load of a cached kernel, so
# warm_up imports them in the caller's thread first (about 5 ms), see there
_COLOURING_IMPORTS = ("numba.cpython.listobj",)


def _dispatchers(descriptor, kind=None, strategy=None, weights=None):
    for module, names in (_COMMON + _DESCRIPTOR.get(descriptor, ()) + _KIND.get(kind, ())
                          + _STRATEGY.get(strategy, ()) + _WEIGHTS.get(weights, ())):
        mod = importlib.import_module(f"lidar_sig.{module}")
        for name in names:
            yield getattr(mod, name)


def load_kernels(descriptor="c3dcm"):
    """Import numba and the modules of the kernels a run of ``descriptor`` calls. A run does so
    before its first timed step (numba takes a good part of a second to import), so that the
    steps' timings are their own work; compiling, or loading from the cache, happens at a
    kernel's first call."""
    for _ in _dispatchers(descriptor):
        pass


def warm_up(key, run):
    """Start ``run``, a tiny run through the kernels of a run of kind ``key`` (descriptor,
    strategy, kind of scales, weights), in a background thread (once per ``key`` and process),
    and return the thread: loading the kernels from the cache (about 0.25 s, mostly numba's first
    call) then overlaps the run's first numpy steps. None when a kernel is not cached: numba
    compiles in the run's own thread then. Numba sets ``sys.stderr`` and back each time it
    builds an error message (it colours them through colorama), thousands of times while it
    compiles; from a second thread that would undo a redirection of stderr the caller's thread
    made meanwhile (as a test or a notebook does). The caller joins the thread before it
    calls a kernel itself, so that two threads never run parallel kernels at once (numba's
    workqueue threading layer would abort). A failure is ignored: the run proper loads, and
    reports, whatever failed here."""
    thread = _WARMING.get(key)
    if thread is None:
        descriptor, strategy, kind, weights = key
        if kernels_cached(descriptor, kind, strategy, weights) is not True:
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


def kernels_cached(descriptor="c3dcm", kind=None, strategy=None, weights=None):
    """True if every kernel a run of ``descriptor`` calls (with scales of ``kind``, "knn" or
    "radius", ``strategy`` and ``weights``, when given) has a compiled version cached for its
    current source and this machine's processor, False if one will be compiled, None if that
    cannot be told (numba's cache layout is not public)."""
    try:
        return all(_cached_here(d) for d in _dispatchers(descriptor, kind, strategy, weights))
    except Exception:  # a numba without this layout: do not guess
        return None


def _cached_here(dispatcher):
    # the cache index (emptied when the source changes) keys each version by its argument types
    # and the processor it was compiled for: a cache made on another machine does not count
    machine = dispatcher.targetctx.codegen().magic_tuple()
    return any(key[1] == machine for key in dispatcher._cache._cache_file._load_index())


#: What the first run after installing is told, once per process (measured on 2 cores: the
#: defaults' kernels compile in 30 s, another descriptor's or strategy's in a few more).
COMPILING = ("compiling the numerical kernels ({what}): about half a minute, once after installing; "
             "later runs load them from the cache")


def announce_compilation(enabled=None, descriptor="c3dcm", kind=None, strategy=None, weights=None):
    """Say once per process, when the kernels a run of ``descriptor`` (scales of ``kind``,
    ``strategy``, ``weights``) calls are about to be compiled, that they are: a LidarSigWarning,
    which the command line prints as one note line on stderr, on a terminal or not (a script, a
    notebook or a GIS calling the command would otherwise wait in silence), and Python shows
    as a warning. Not when ``enabled`` is False (``--quiet``, or a worker process of a tiled
    run, whose main process says it)."""
    global _ANNOUNCED
    if _ANNOUNCED or enabled is False:
        return
    if kernels_cached(descriptor, kind, strategy, weights) is False:
        from .errors import LidarSigWarning

        _ANNOUNCED = True
        what = ", ".join(x for x in (descriptor, strategy, {"knn": "k-nearest", "radius": "radii"}.get(kind),
                                     f"{weights} weights" if weights else None) if x)
        warnings.warn(COMPILING.format(what=what), LidarSigWarning, stacklevel=3)
