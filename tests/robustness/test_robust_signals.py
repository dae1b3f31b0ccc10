"""Interrupts (issue 9, item 5): SIGTERM and Ctrl-C (SIGINT) at any moment of a run.

The run ends with one line and exit status 128 + the signal, leaves no temporary file and no
partial output, and a previous output stays as it was. (A SIGKILL cannot be caught: its
leftover is tested in test_robust_outputs; a signal once the outputs are in place, in
test_robust_hostile.)
"""
import os
import signal
import subprocess
import sys
import time

import laspy
import pytest

from conftest import DATA, SAMPLES, need_data
from robustness.helpers import digests, leftovers

BIG = DATA / "ahn3_delft" / "ahn3_cropped_1.laz"  # 640k points: the LAZ write takes a while


def _interruptible():
    # a shell's background job starts with SIGINT ignored, and Python keeps an ignored SIGINT
    # ignored: give the child the disposition of a command typed at a terminal
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def start(*args, cwd=None):
    return subprocess.Popen([sys.executable, "-m", "lidar_sig", *map(str, args)], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, cwd=cwd, stdin=subprocess.DEVNULL,
                            preexec_fn=_interruptible)


def wait_for_temp(folder, proc, limit=120):
    """Until a temporary output file appears in ``folder`` (the write has begun)."""
    end = time.monotonic() + limit
    while time.monotonic() < end and proc.poll() is None:
        if leftovers(folder):
            return True
        time.sleep(0.002)
    return False


def assert_interrupted(proc, signum):
    out, err = proc.communicate(timeout=120)
    assert proc.returncode == 128 + signum, (proc.returncode, err)
    lines = err.strip().splitlines()
    assert len(lines) == 1 and "interrupted" in lines[0] and signal.Signals(signum).name in lines[0], err
    assert "Traceback" not in err and "Exception ignored" not in err


@pytest.mark.parametrize("signum", [signal.SIGTERM, signal.SIGINT])
@pytest.mark.parametrize("name", ["o.laz", "o.h5"])
def test_signal_during_the_write_leaves_the_previous_output(tmp_path, signum, name):
    src = need_data(BIG)
    command = "signature" if name.endswith(".h5") else "saliency"
    out = tmp_path / name
    out.write_bytes(b"previous")
    before = digests(out)
    proc = start(command, src, "-o", out, "--overwrite", "-q")
    if not wait_for_temp(tmp_path, proc):
        proc.kill()
        pytest.fail(f"the run ended before its write began: {proc.communicate()[1]}")
    proc.send_signal(signum)
    assert_interrupted(proc, signum)
    assert digests(out) == before and not leftovers(tmp_path)


@pytest.mark.parametrize("delay", [0.3, 1.0, 2.0, 3.0, 4.5])
@pytest.mark.parametrize("command", ["saliency", "signature", "compare"])
def test_sigterm_at_any_moment_leaves_a_whole_output_or_none(tmp_path, command, delay):
    src = need_data(DATA / "ahn3_delft" / "ahn3_cropped_2.laz")
    out = tmp_path / ("o.h5" if command == "signature" else "o.laz")
    args = [command, src] + ([SAMPLES / "epoch1.laz"] if command == "compare" else ["-o", out])
    proc = start(*args, "-q")
    time.sleep(delay)
    proc.send_signal(signal.SIGTERM)
    stdout, err = proc.communicate(timeout=180)
    assert not leftovers(tmp_path), err
    # compare writes no file: it has finished when its table is printed whole
    finished = out.exists() or (command == "compare" and "L1 " in stdout)
    if finished:
        # finished before the signal (status 0), or the signal came once the output was in
        # place (143, said so): the output is whole
        if command == "saliency":
            assert len(laspy.read(out).points) == 208432
        elif command == "signature":
            import lidar_sig as ls

            assert ls.load_signature(out).n_points > 0
    if proc.returncode == -signal.SIGTERM:
        # killed by the signal itself while Python was still importing, before the command line
        # could install its handler: nothing had been opened for writing yet
        assert err == "" and not out.exists()
    elif proc.returncode != 0:
        assert proc.returncode == 128 + signal.SIGTERM, err
        assert len(err.strip().splitlines()) == 1 and "SIGTERM" in err and "Traceback" not in err
        assert not out.exists() or "whole" in err, err


def test_ctrl_c_while_computing_is_one_line(tmp_path):
    proc = start("saliency", need_data(BIG), "-o", tmp_path / "o.laz", "-q")
    time.sleep(2.0)
    proc.send_signal(signal.SIGINT)
    assert_interrupted(proc, signal.SIGINT)
    assert not os.listdir(tmp_path)


@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM])
def test_signal_while_starting_is_one_line(tmp_path, signum):
    # the libraries take a second to load: a signal then used to print a traceback (Ctrl-C)
    proc = start("saliency", SAMPLES / "epoch1.laz", "-o", tmp_path / "o.laz", "-q")
    time.sleep(0.15)
    proc.send_signal(signum)
    assert_interrupted(proc, signum)
    assert not os.listdir(tmp_path)

