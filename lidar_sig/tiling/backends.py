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


#: Seconds to reach a Dask scheduler: the TCP connection and the handshake together.
CONNECT_SECONDS = 20.0
#: Seconds a run waits for a first worker of a cluster that has none.
NO_WORKER_SECONDS = 30.0
#: Seconds a run waits while the cluster has no worker left, or every worker is paused at its
#: memory limit, before it ends with one line naming the fix.
STALLED_SECONDS = 60.0
#: Seconds between two looks at the cluster's state while no task finishes.
CHECK_SECONDS = 2.0


class DaskCluster:
    """Run tasks on the dask.distributed scheduler at ``address`` (``tcp://host:8786``).

    No run waits without end: reaching the scheduler is bounded (:data:`CONNECT_SECONDS`, the
    handshake included; a service that is not Dask is one line), a cluster without workers is
    one line, and while no task finishes the scheduler's state is read: no worker left, or every
    worker paused at its memory limit, for :data:`STALLED_SECONDS` ends the run in one line naming
    the fix. A task's arguments are small (a shared argument goes once, as a task of its own that
    the cluster computes again if the worker holding it is lost)."""

    __repr__ = InProcess.__repr__

    def __init__(self, address):
        try:
            import distributed  # noqa: F401
        except ImportError:
            raise LidarSigError(f"{arg('scheduler')} needs dask.distributed: pip install 'lidar_sig[dask]'") from None
        self.address = address = _tcp_address(address)
        _probe(address)
        self._quiet = _quiet_distributed().__enter__()  # until close
        try:
            self.client = _connect(address)
        except LidarSigError:
            self._quiet.__exit__()
            raise
        n = self._wait_for_workers()
        self.workers = max(1, n)
        self.description = f"Dask scheduler {address} ({n} workers)"

    def _wait_for_workers(self):
        """How many workers the cluster has (paused ones too: :meth:`run` watches them), once it
        has one; a LidarSigError when it has none for :data:`NO_WORKER_SECONDS`."""
        import time

        end = time.monotonic() + NO_WORKER_SECONDS
        while True:
            try:
                n = len(self._workers())
            except Exception as exc:  # the scheduler gone meanwhile
                self.close()
                raise self._lost(exc) from None
            if n or time.monotonic() > end:
                break
            time.sleep(0.25)
        if not n:
            self.close()
            raise LidarSigError(f"the Dask scheduler at {self.address} has no workers (waited {NO_WORKER_SECONDS:g} s); "
                                f"start some (dask worker {self.address}), then run it again")
        return n

    def _workers(self):
        return self.client.scheduler_info(n_workers=-1).get("workers", {}) if _takes_n_workers(self.client) \
            else self.client.scheduler_info().get("workers", {})

    def run(self, fn, items):
        items = list(items)
        shared = {}  # id of an argument object -> the future of the task that holds it

        def small(value):
            if isinstance(value, (str, bytes, int, float, bool, type(None), os.PathLike, tuple, list, dict)):
                return value
            if id(value) not in shared:  # once per run, computed again by the cluster if lost
                shared[id(value)] = self.client.submit(_given, value, pure=False)
            return shared[id(value)]

        try:
            futures = {self.client.submit(fn, *map(small, item), pure=False): item for item in items}
        except Exception as exc:
            raise self._lost(exc) from None
        yield from self._results(futures)
        for fut in shared.values():
            fut.release()

    def _results(self, futures):
        from distributed import wait

        pending = set(futures)
        stalled = None  # since when the cluster has had no running worker
        while pending:
            try:
                done, pending = wait(list(pending), timeout=CHECK_SECONDS, return_when="FIRST_COMPLETED")
                done, pending = set(done), set(pending)
            except TimeoutError:
                done = set()
            except Exception as exc:  # the scheduler gone (CommClosedError, OSError)
                raise self._lost(exc) from None
            if done:
                stalled = None
            else:
                stalled = self._check(stalled)
            for fut in done:
                item = futures[fut]
                if fut.status == "error":
                    yield item, None, fut.exception()
                elif fut.status == "cancelled":  # the scheduler or the worker holding it was lost
                    raise self._lost(None)
                else:
                    yield item, fut.result(), None
                fut.release()

    def _check(self, stalled):
        """While no task finishes: the time since when no worker could run one (None while some
        can); a LidarSigError once that has lasted :data:`STALLED_SECONDS`."""
        import time

        try:
            workers = self._workers()
        except Exception as exc:
            raise self._lost(exc) from None
        running = [w for w in workers.values() if w.get("status", "running") not in ("paused", "closing", "closed")]
        if running:
            return None
        now = time.monotonic()
        if stalled is None:
            return now
        if now - stalled < STALLED_SECONDS:
            return stalled
        if workers:
            raise LidarSigError(f"every worker of the Dask cluster at {self.address} has been paused at its memory limit "
                                f"for {STALLED_SECONDS:g} s: give the workers more memory (dask worker "
                                f"--memory-limit) or a smaller {arg('memory')} (smaller tiles), then run it again "
                                f"with {arg('resume', True)}")
        raise LidarSigError(f"the Dask cluster at {self.address} has had no worker for {STALLED_SECONDS:g} s: start "
                            f"workers (dask worker {self.address}), then run it again with {arg('resume', True)}")

    def _lost(self, exc):
        why = f" ({_reason(exc)})" if exc is not None else ""
        return LidarSigError(f"the Dask cluster at {self.address} lost the run's tasks (scheduler or workers gone{why}); "
                             f"check the cluster, then run the same job with {arg('resume', True)}")

    def close(self):
        client = getattr(self, "client", None)
        if client is not None:
            try:
                client.close(timeout=5)
            except Exception:  # the scheduler is gone already: nothing to close
                pass
        quiet = getattr(self, "_quiet", None)
        if quiet is not None:
            quiet.__exit__()
            self._quiet = None


def _given(value):
    """A task that holds ``value`` for the tasks that take it (see :meth:`DaskCluster.run`)."""
    return value


def _takes_n_workers(client):
    import inspect

    return "n_workers" in inspect.signature(client.scheduler_info).parameters


def _reason(exc):
    return f"{type(exc).__name__}: {exc}" if str(exc) else type(exc).__name__


def _tcp_address(address):
    """``address`` as ``tcp://host:port``; a LidarSigError for another protocol or no port."""
    scheme, sep, rest = address.partition("://")
    if not sep:
        scheme, rest = "tcp", address
    if scheme.lower() != "tcp":
        raise LidarSigError(f"{arg('scheduler', address)}: lidar-sig reaches a Dask scheduler over tcp:// only "
                            f"({scheme}:// is not supported: tls:// needs certificates it does not take, ucx:// the UCX "
                            "libraries); give tcp://host:port")
    host, _, port = rest.rpartition(":")
    if not host or not port.isdigit() or not 0 < int(port) < 65536:
        raise LidarSigError(f"{arg('scheduler', address)} is not an address such as tcp://host:8786 (a host and a "
                            "port)")
    return f"tcp://{host}:{int(port)}"


#: Largest first message a Dask scheduler is taken to announce (bytes): its handshake is a few
#: dozen; a service speaking another protocol first (an SSH or SMTP banner) reads as exabytes.
MOST_HANDSHAKE_BYTES = 2**30


def _probe(address):
    """Refuse, in one line, an address where no server listens or where a service that is not a
    Dask scheduler does: one that closes the connection at once, or speaks another protocol
    first (a Dask scheduler's first 8 bytes are the small length of its handshake, little-endian;
    another service's banner read so would make the client allocate exabytes)."""
    import socket

    host, _, port = address[len("tcp://"):].rpartition(":")
    host = host.strip("[]")
    try:
        sock = socket.create_connection((host, int(port)), timeout=CONNECT_SECONDS)
    except OSError as exc:
        raise LidarSigError(f"cannot reach the Dask scheduler at {address} ({_reason(exc)}); check the address "
                            "and that the scheduler runs") from None
    with sock:
        sock.settimeout(1.0)
        said = b""
        try:
            while len(said) < 8:
                got = sock.recv(64)
                if not got:
                    break
                said += got
        except (socket.timeout, TimeoutError):
            if not said:
                return  # silent: the bounded handshake (_connect) says whether it is a scheduler
        except OSError as exc:
            raise LidarSigError(f"cannot reach the Dask scheduler at {address} ({_reason(exc)}); check the address "
                                "and that the scheduler runs") from None
        if len(said) >= 8 and int.from_bytes(said[:8], "little") <= MOST_HANDSHAKE_BYTES:
            return  # a scheduler's handshake
        why = f"it speaks another protocol: {said[:40]!r}" if said else "it closed the connection at once"
    raise LidarSigError(f"the server at {address} is not a Dask scheduler ({why}); give the address of a "
                        "dask.distributed scheduler (tcp://host:8786)")


def _connect(address):
    """A Client of the scheduler at ``address``, the TCP connection and the handshake bounded
    together by :data:`CONNECT_SECONDS` (a server that accepts and never answers is refused)."""
    import threading

    from distributed import Client

    got = {}

    def connect():
        try:
            got["client"] = Client(address, timeout=f"{CONNECT_SECONDS:g}s")
        except BaseException as exc:  # noqa: BLE001 - reported by the caller's thread
            got["error"] = exc

    worker = threading.Thread(target=connect, daemon=True, name="lidar-sig-dask-connect")
    worker.start()
    worker.join(CONNECT_SECONDS + 5)
    if "client" in got:
        return got["client"]
    why = _reason(got["error"]) if "error" in got else f"no answer to the handshake in {CONNECT_SECONDS:g} s"
    raise LidarSigError(f"cannot reach the Dask scheduler at {address} ({why}); check the address and that a "
                        "dask.distributed scheduler runs there")


class _quiet_distributed:
    """While in the block, distributed's own log lines (a connection closed, a task cancelled)
    stay off stderr: what they report ends the run in one line of ours."""

    def __enter__(self):
        import logging

        self._logger = logging.getLogger("distributed")
        self._level = self._logger.level
        self._logger.setLevel(logging.CRITICAL + 1)
        return self

    def __exit__(self, *exc):
        self._logger.setLevel(self._level)
        return False


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
