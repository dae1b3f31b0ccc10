"""The defects of the third hostile sweep (issue 46) in Dask runs and memory budgets: a scheduler
address where no scheduler is (a server that never answers, one that speaks another protocol
first, tls:// and ucx://), a cluster without workers, workers lost or paused at their memory
limit, the plan sent to a cluster as one large graph, and budgets in bytes.

Each case is met as a user meets it, the command in this process (tests/command_line.py) and a
real dask.distributed cluster on loopback where one is needed, every case bounded in time. It
must end as the project promises: exit status 2 and one line naming the value or the cluster
and the fix, no traceback, no library warning on stderr, nothing waiting without end.
"""
import contextlib
import socket
import subprocess
import sys
import threading
import time

import numpy as np
import pytest

import lidar_sig as ls
from command_line import run
from conftest import SAMPLES
from robustness.helpers import assert_one_line_error

EPOCH1 = SAMPLES / "epoch1.laz"
EPOCH2 = SAMPLES / "epoch2.laz"


@contextlib.contextmanager
def server(banner=None, close=False):
    """A TCP server on loopback that accepts and then stays silent, says ``banner`` first, or
    closes at once; yields its tcp:// address."""
    sock = socket.socket()
    sock.bind(("127.0.0.1", 0))
    sock.listen(16)
    sock.settimeout(0.2)
    held, stop = [], threading.Event()

    def serve():
        while not stop.is_set():
            try:
                conn, _ = sock.accept()
            except OSError:
                continue
            if banner:
                conn.sendall(banner)
            if close:
                conn.close()
            else:
                held.append(conn)

    thread = threading.Thread(target=serve, daemon=True)
    thread.start()
    try:
        yield f"tcp://127.0.0.1:{sock.getsockname()[1]}"
    finally:
        stop.set()
        thread.join(2)
        for conn in held:
            conn.close()
        sock.close()


def changes_on(address, tmp_path, *extra):
    return run("changes", EPOCH1, EPOCH2, "-o", tmp_path / "map.tif", "--scheduler", address, *extra)


@pytest.fixture
def quick(monkeypatch):
    """The bounds of a Dask run shortened, so that a case ends in seconds."""
    from lidar_sig.tiling import backends

    monkeypatch.setattr(backends, "CONNECT_SECONDS", 3.0)
    monkeypatch.setattr(backends, "NO_WORKER_SECONDS", 3.0)
    monkeypatch.setattr(backends, "STALLED_SECONDS", 4.0)
    monkeypatch.setattr(backends, "CHECK_SECONDS", 0.5)
    return backends


def test_a_server_that_never_answers_the_handshake_is_one_line_in_bounded_time(tmp_path, quick):
    pytest.importorskip("distributed", reason="the dask extra is not installed")
    with server() as address:
        start = time.monotonic()
        proc = changes_on(address, tmp_path)
    assert time.monotonic() - start < 30
    assert_one_line_error(proc, address, "handshake")
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("banner, close", [(b"SSH-2.0-OpenSSH_9.6\r\n", False), (b"220 mail ESMTP\r\n", True),
                                           (None, True)])
def test_a_service_that_is_not_dask_is_one_line_without_a_huge_allocation(tmp_path, quick, banner, close):
    pytest.importorskip("distributed", reason="the dask extra is not installed")
    with server(banner, close) as address:
        proc = changes_on(address, tmp_path)
    assert_one_line_error(proc, address, "not a Dask scheduler")
    assert "MemoryError" not in proc.stderr and "EiB" not in proc.stderr


@pytest.mark.parametrize("address", ["tls://127.0.0.1:8786", "ucx://127.0.0.1:8786", "inproc://x", "tcp://host"])
def test_an_address_of_another_protocol_or_without_port_is_one_line(tmp_path, address):
    pytest.importorskip("distributed", reason="the dask extra is not installed")
    proc = changes_on(address, tmp_path)
    assert_one_line_error(proc, address, "tcp://")
    assert "TypeError" not in proc.stderr


@pytest.fixture(scope="module")
def distributed():
    return pytest.importorskip("distributed", reason="the dask extra is not installed")


def test_a_cluster_without_workers_is_one_line(tmp_path, quick, distributed):
    with distributed.LocalCluster(n_workers=0, processes=True, dashboard_address=None) as cluster:
        proc = changes_on(cluster.scheduler_address, tmp_path, "--tile-size", "40")
    assert_one_line_error(proc, "no workers", "dask worker")
    assert "CancelledError" not in proc.stderr


def test_workers_paused_at_their_memory_limit_end_the_run_in_one_line(tmp_path, quick, distributed):
    import dask

    # workers that pause at once: their memory limit is below what a worker holds at rest
    with dask.config.set({"distributed.worker.memory.pause": 0.05, "distributed.worker.memory.terminate": False,
                          "distributed.worker.memory.spill": False, "distributed.worker.memory.target": False}):
        with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=True, memory_limit="400MiB",
                                      dashboard_address=None) as cluster:
            with distributed.Client(cluster.scheduler_address, timeout="20s") as client:
                deadline = time.monotonic() + 30
                while time.monotonic() < deadline and not any(
                        w.get("status") == "paused" for w in client.scheduler_info()["workers"].values()):
                    time.sleep(0.3)
                if not any(w.get("status") == "paused" for w in client.scheduler_info()["workers"].values()):
                    pytest.skip("this dask.distributed did not pause its worker at the limit given")
            start = time.monotonic()
            proc = changes_on(cluster.scheduler_address, tmp_path, "--tile-size", "40")
    assert time.monotonic() - start < 120
    assert_one_line_error(proc, "paused at its memory limit", "--memory-limit")


def test_a_cluster_that_loses_its_workers_ends_the_run_in_one_line(tmp_path, quick, distributed):
    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=True,
                                  dashboard_address=None) as cluster:
        def kill_workers():
            time.sleep(4)
            for worker in list(cluster.workers.values()):
                with contextlib.suppress(Exception):
                    cluster.sync(worker.close)
            cluster.scale(0)

        threading.Thread(target=kill_workers, daemon=True).start()
        start = time.monotonic()
        proc = changes_on(cluster.scheduler_address, tmp_path, "--tile-size", "40")
    assert time.monotonic() - start < 180
    if proc.returncode == 0:
        pytest.skip("the run finished before its workers were lost")
    assert_one_line_error(proc, "no worker", "--resume")
    assert "CommClosedError" not in proc.stderr and "CancelledError" not in proc.stderr


def test_a_worker_killed_mid_run_is_replaced_and_the_run_ends_with_the_local_map(tmp_path, distributed):
    # the nanny starts a new worker; what the lost one held is computed again (no task's argument
    # lives only on one worker), and no library warning reaches stderr
    local = run("changes", EPOCH1, EPOCH2, "-o", tmp_path / "local.tif", "--tile-size", "40", "--workers", "1")
    assert local.returncode == 0, local.stderr
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=None) as cluster:
        def kill_one():
            time.sleep(3)
            with distributed.Client(cluster.scheduler_address) as client:
                info = client.scheduler_info()["workers"]
                pids = client.run(lambda: __import__("os").getpid(), workers=list(info)[:1])
            for pid in pids.values():
                subprocess.run(["kill", "-9", str(pid)], check=False)

        threading.Thread(target=kill_one, daemon=True).start()
        proc = subprocess.run([sys.executable, "-m", "lidar_sig", "changes", EPOCH1, EPOCH2, "-o",
                               tmp_path / "dask.tif", "--tile-size", "40", "--scheduler", cluster.scheduler_address],
                              capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr
    assert "Sending large graph" not in proc.stderr and "Warning" not in proc.stderr, proc.stderr
    import rasterio

    with rasterio.open(tmp_path / "local.tif") as a, rasterio.open(tmp_path / "dask.tif") as b:
        assert np.array_equal(a.read(), b.read(), equal_nan=True)


def test_a_task_of_a_change_map_carries_no_signature(tmp_path):
    # the set's signature (tens of MiB) stays in the main process: what a task gets is small
    import pickle

    from lidar_sig.tiling.run_set import run_set

    run_ = run_set(ls.Pipeline(progress=False), [EPOCH1], work=tmp_path / "work", tile_size=40.0)
    assert run_.signature is not None
    assert len(pickle.dumps(run_)) < 200_000 < len(pickle.dumps(run_.signature))


@pytest.mark.parametrize("value", ["500B", "1B", "2", "4096"])
def test_a_budget_in_bytes_is_refused_as_too_small_naming_the_least(tmp_path, value):
    proc = run("changes", EPOCH1, EPOCH2, "-o", tmp_path / "map.tif", "--memory", value)
    assert_one_line_error(proc, f"--memory {value}", "give at least")
    assert list(tmp_path.iterdir()) == []
