"""Where tiles run: in this process, on local worker processes, or on a dask.distributed cluster.

Every backend takes the same task functions and arguments and yields ``(item, result, error)``
as tasks finish, so a failed task is reported and the others go on. Tasks exchange only small
values (paths, statistics): points and results travel through the work folder, which every
worker must see at the same path (see docs/scale-out.md).
"""
from __future__ import annotations

import concurrent.futures as cf
import multiprocessing
import os
import sys

from ..base.errors import LidarSigError, arg, whole_number


def _init_worker(threads):
    # Each process gets its share of the cores for the compiled kernels (numba threads), so
    # that N workers do not start N x cores threads.
    import numba

    numba.set_num_threads(max(1, min(threads, numba.config.NUMBA_NUM_THREADS)))


def cores() -> int:
    """The cores this process may run on (those the system lets it use, e.g. in a container or
    under ``taskset``; else all of the machine's)."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except (AttributeError, OSError):  # not on Linux
        return os.cpu_count() or 1


class InProcess:
    """Run tasks one after the other in this process (``--workers 1``)."""

    description = "1 process"
    workers = 1

    def __repr__(self):
        return f"<{type(self).__name__} backend: {self.description}>"

    def run(self, fn, items):
        for item in items:
            try:
                yield item, fn(*item), None
            except LidarSigError as exc:
                yield item, None, exc
            except Exception as exc:  # a tile's failure must not lose the others
                yield item, None, exc

    def close(self):
        pass


class LocalProcesses:
    """Run tasks on ``workers`` local processes (started fresh, not forked: the compiled
    kernels' thread pools do not survive a fork)."""

    __repr__ = InProcess.__repr__

    def __init__(self, workers):
        self.workers = int(workers)  # how many tasks run at once
        self.description = f"{self.workers} local processes"
        threads = max(1, cores() // self.workers)
        self.pool = cf.ProcessPoolExecutor(self.workers, mp_context=multiprocessing.get_context("spawn"),
                                           initializer=_init_worker, initargs=(threads,))

    def run(self, fn, items):
        futures = {self.pool.submit(fn, *item): item for item in items}
        for fut in cf.as_completed(futures):
            try:
                yield futures[fut], fut.result(), None
            except cf.process.BrokenProcessPool as exc:
                raise LidarSigError(_died(exc)) from None
            except Exception as exc:
                yield futures[fut], None, exc

    def close(self):
        self.pool.shutdown(cancel_futures=True)


def _died(exc):
    """Why a worker process died, for the user: too little memory, or a script whose top-level
    code starts the job again in every worker (a worker imports the main script)."""
    why = (f"a worker process died ({exc}); too little memory? use a smaller {arg('tile_size')} or fewer "
           f"{arg('workers')}, then run it again")
    main = sys.modules.get("__main__")
    script = getattr(main, "__file__", None)
    if script and getattr(getattr(main, "__spec__", None), "name", None) is None:
        why += (f"; or, if {script} runs the job in its top-level code, put that code under "
                "`if __name__ == \"__main__\":` (each worker process imports the script), or use one process "
                f"({arg('workers', 1)})")
    return why


class DaskCluster:
    """Run tasks on the dask.distributed scheduler at ``address`` (``tcp://host:8786``)."""

    __repr__ = InProcess.__repr__

    def __init__(self, address):
        try:
            from distributed import Client
        except ImportError:
            raise LidarSigError(f"{arg('scheduler')} needs dask.distributed: pip install 'lidar_sig[dask]'") from None
        try:
            self.client = Client(address, timeout="20s")
        except (OSError, TimeoutError, ValueError) as exc:
            raise LidarSigError(f"cannot reach the Dask scheduler at {address} ({exc}); check the address "
                                "and that the scheduler runs") from None
        n = len(self.client.scheduler_info().get("workers", {}))
        self.workers = max(1, n)
        self.description = f"Dask scheduler {address} ({n} workers)"

    def run(self, fn, items):
        from distributed import as_completed

        items = list(items)
        futures = {}
        # the plan every task of a run shares goes to the workers once, not once per task
        shared = items[0][0] if items and all(item[0] is items[0][0] for item in items) else None
        first = self.client.scatter(shared, broadcast=True, hash=False) if shared is not None else None
        for item in items:
            args = (first, *item[1:]) if shared is not None else item
            futures[self.client.submit(fn, *args, pure=False)] = item
        for fut in as_completed(list(futures)):
            item = futures[fut]
            if fut.status == "error":
                yield item, None, fut.exception()
            elif fut.status == "cancelled":  # the scheduler or the worker holding it was lost
                raise LidarSigError("the Dask cluster lost the run's tasks (scheduler or workers gone); "
                                    f"check the cluster, then run the same job with {arg('resume', True)}")
            else:
                yield item, fut.result(), None
            fut.release()

    def close(self):
        self.client.close()


def executor(workers=None, scheduler=None):
    """The backend for ``workers`` local processes (None: all cores; 1: this process) or a
    dask.distributed ``scheduler`` (:class:`lidar_sig.Execution` checks both)."""
    if scheduler:
        if workers:
            raise LidarSigError(f"give {arg('workers')} or {arg('scheduler')}, not both (the cluster has its own "
                                "workers)")
        return DaskCluster(scheduler)
    if workers is not None:
        workers = whole_number(workers, arg("workers"), low=1)
    n = workers or cores()
    return InProcess() if n == 1 else LocalProcesses(n)
