"""The cells' metrics and resamples of a change map of one block on every core: the compared
cells split into parts, each part computed in a process forked from the map's own (so that it
shares the binned epochs without copying or pickling them), the values gathered here. Each cell
draws its resamples from its own random stream, so the values do not depend on the part a cell
falls in nor on the number of processes: the map is the same on one core or many. (Both epochs'
saliency at once in two forked processes was slower than one after the other: docs/performance.md,
"The change map beside M3C2".)"""
from __future__ import annotations

import contextlib
import multiprocessing
import signal
import sys
import threading
import warnings

import numpy as np

from ._cells import CHANGE_KEYS, cell_observed, cell_replicates
from ._lod import REPLICATES

#: Fewest compared cells worth a process each: below, the forks cost more than they save.
CELLS_PER_PROCESS = 16
#: Parts per process, so that a process that finishes early takes another.
PARTS_PER_PROCESS = 4
#: The job of the forked processes: set before they start, read by them (inherited, not sent).
_JOB = {}


def cell_values(table, binned, classes, *, render, frame, seed, stream, workers=None, progress=None):
    """Fill the table's metrics (:func:`~lidar_sig.change_map._cells.cell_observed`) and return
    the replicates (:func:`~lidar_sig.change_map._cells.cell_replicates`) of its valid cells, in
    one pass over them,
    on ``workers`` processes (None: the cores this process may use), forked where this
    process may fork (:func:`may_fork`) and the cells are enough (:data:`CELLS_PER_PROCESS`
    each); else here."""
    from ..tiling.backends import cores

    cells = np.flatnonzero(table["valid"])
    workers = min(workers or cores(), len(cells) // CELLS_PER_PROCESS)
    options = dict(render=render, frame=frame)
    null = np.full((len(table), 2 * REPLICATES, len(CHANGE_KEYS)), np.nan)
    if workers < 2 or not may_fork():
        if progress is not None:
            progress.note(processes=1)
        for c in (progress.track(cells, unit="cell") if progress is not None else cells):
            observed, null[c] = _values(c, table, binned, classes, seed, stream, options)
            for m, k in enumerate(CHANGE_KEYS):
                table[k][c] = observed[m]
        return null
    import cv2
    from concurrent.futures import ProcessPoolExecutor

    parts = np.array_split(cells, workers * PARTS_PER_PROCESS)
    if progress is not None:
        progress.note(processes=workers)
    _JOB.update(table=table, binned=binned, classes=classes, options=options, seed=seed, stream=stream)
    threads = cv2.getNumThreads()
    cv2.setNumThreads(1)  # OpenCV's thread pool does not survive a fork: the children run without it
    try:
        with _forking(), ProcessPoolExecutor(workers, mp_context=multiprocessing.get_context("fork"),
                                             initializer=_child) as pool:
            done = pool.map(_part, parts)
            for part, observed, replicates in (progress.track(done, total=len(parts), unit="part")
                                               if progress is not None else done):
                for m, k in enumerate(CHANGE_KEYS):
                    table[k][part] = observed[:, m]
                null[part] = replicates
    finally:
        _JOB.clear()
        cv2.setNumThreads(threads)
    return null


def may_fork():
    """True where this process may fork its work: Linux (elsewhere the libraries' thread pools do
    not survive a fork), not itself a worker of a process pool, and no thread but this one runs
    Python (a fork copies only the calling thread; a lock another thread held would stay locked
    in the child: in a notebook, under a test runner, beside a Dask client the work stays in
    this process). The compiled kernels' thread pool may run: the children do not use it."""
    return (sys.platform.startswith("linux") and not multiprocessing.current_process().daemon
            and threading.active_count() == 1)


def _child():
    """A child leaves Ctrl-C and termination to the map's process, which ends the pool."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)


def _part(cells):
    """(cells, their metrics (n, K), their replicates (n, 2R, K)) in a forked process."""
    job = _JOB
    values = [_values(c, job["table"], job["binned"], job["classes"], job["seed"], job["stream"], job["options"])
              for c in cells]
    return cells, np.array([v[0] for v in values]), np.array([v[1] for v in values])


def _values(c, table, binned, classes, seed, stream, options):
    """(metrics (K,), replicates (2R, K)) of cell ``c``."""
    sizes = (int(table["points_a"][c]), int(table["points_b"][c]))
    return (cell_observed(binned, c, classes, **options),
            cell_replicates(binned, c, sizes, classes, seed=seed, stream=stream, **options))


@contextlib.contextmanager
def _forking():
    """Python 3.12 and later warn of a fork in a process with threads (the compiled kernels' pool):
    the children here run numpy and OpenCV on one thread and take no lock that pool holds."""
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message=r".*fork\(\) may lead to deadlocks", category=DeprecationWarning)
        yield
