"""Outputs on hostile file systems (issue 9, items 2, 3 and 6): full, read-only, immutable;
several outputs of one command; a run killed outright.

A failure must say so in one line naming the output and the fix, leave no temporary file,
leave a previous output as it was, and not report success.
"""
import os
import signal
import subprocess
import sys
import time

import pytest

from command_line import run, run_process
from conftest import SAMPLES
from robustness.helpers import assert_one_line_error, digests, fill, leftovers, mounted_tmpfs

SRC = SAMPLES / "epoch1.laz"


@pytest.mark.parametrize("name", ["o.laz", "o.las", "o.ply", "o.pcd", "o.xyz", "o.h5", "o.png"])
def test_full_disk_is_one_line_and_keeps_the_previous_output(tmp_path, name):
    command = "signature" if name.endswith((".h5", ".png")) else "saliency"
    with mounted_tmpfs(tmp_path, size="8m") as fs:
        out = fs / name
        first = run(command, SRC, "-o", out, "-q")
        assert first.returncode == 0, first.stderr
        before = digests(out)
        fill(fs, leave=4096)
        proc = run(command, SRC, "-o", out, "--overwrite")
        assert_one_line_error(proc, name, "no space left")
        assert digests(out) == before and not leftovers(fs)
        assert "wrote" not in proc.stdout


@pytest.mark.parametrize("command,name", [("saliency", "o.laz"), ("signature", "o.h5"), ("signature", "o.png")])
def test_read_only_folder_is_one_line_before_any_work(tmp_path, command, name):
    with mounted_tmpfs(tmp_path, read_only=True) as fs:
        start = time.monotonic()
        proc = run(command, SRC, "-o", fs / name)
        assert_one_line_error(proc, name, "not writable")
        assert time.monotonic() - start < 30  # refused before the saliency was computed
        assert not os.listdir(fs)


def test_immutable_folder_is_one_line(tmp_path):
    folder = tmp_path / "locked"
    folder.mkdir()
    made = subprocess.run(["chattr", "+i", str(folder)], capture_output=True, text=True)
    if made.returncode != 0:
        pytest.skip(f"cannot make an immutable folder here ({made.stderr.strip()}); needs root on ext4")
    try:
        proc = run("saliency", SRC, "-o", folder / "o.laz")
        assert_one_line_error(proc, "o.laz")
        assert not os.listdir(folder)
    finally:
        subprocess.run(["chattr", "-i", str(folder)], capture_output=True)


def test_signature_outputs_are_checked_together_before_any_work(tmp_path):
    # item 6: `-o s.h5 --png same.png --sg same.png` wrote two files, then failed
    proc = run("signature", SRC, "-o", tmp_path / "s.h5", "--png", tmp_path / "same.png", "--sg", tmp_path / "same.png")
    assert_one_line_error(proc, "same.png", "given twice")
    assert not os.listdir(tmp_path)
    missing = run("signature", SRC, "-o", tmp_path / "s.h5", "--png", tmp_path / "nowhere" / "s.png")
    assert_one_line_error(missing, "nowhere", "does not exist")
    assert not os.listdir(tmp_path)
    (tmp_path / "there.png").write_bytes(b"keep")
    exists = run("signature", SRC, "-o", tmp_path / "s.h5", "--sg", tmp_path / "there.png")
    assert_one_line_error(exists, "there.png", "--overwrite")
    assert sorted(os.listdir(tmp_path)) == ["there.png"] and (tmp_path / "there.png").read_bytes() == b"keep"


def test_signature_writes_all_outputs_or_none_when_the_disk_fills(tmp_path):
    # room for the archive, not for the images after it: nothing may be left of any
    sized = run("signature", SRC, "-o", tmp_path / "s.h5", "-q")
    assert sized.returncode == 0, sized.stderr
    room = (tmp_path / "s.h5").stat().st_size + 16384
    with mounted_tmpfs(tmp_path, size="8m") as fs:
        fill(fs, leave=room)
        proc = run("signature", SRC, "-o", fs / "s.h5", "--png", fs / "s.png", "--sg", fs / "g.png")
        assert_one_line_error(proc, "no space left")
        assert sorted(os.listdir(fs)) == ["filler"]


def test_sigkill_leftover_is_recognisable_and_removed_by_the_next_run(tmp_path):
    out = tmp_path / "o.laz"
    child = subprocess.Popen([sys.executable, "-c", (
        "import time, lidar_sig as ls\n"
        "from lidar_sig.io.atomic import atomic_output\n"
        f"with atomic_output({str(out)!r}) as tmp:\n"
        "    tmp.write_bytes(b'half')\n"
        "    print(tmp.name, flush=True)\n"
        "    time.sleep(60)\n")], stdout=subprocess.PIPE, text=True)
    name = child.stdout.readline().strip()
    child.send_signal(signal.SIGKILL)
    child.wait()
    assert leftovers(tmp_path) == [name]
    assert name.startswith(".o.laz.") and name.endswith(".tmp.laz") and f".{child.pid}." in name
    proc = run("saliency", SRC, "-o", out, "-q")
    assert proc.returncode == 0, proc.stderr
    assert not leftovers(tmp_path) and out.exists()


def test_a_running_writers_temporary_file_is_left_alone(tmp_path):
    # another live process writing the same output keeps its temporary file
    live = tmp_path / f".o.laz.{os.uname().nodename.replace('.', '-')[:32]}.{os.getpid()}.abcd.tmp.laz"
    live.write_bytes(b"in progress")
    proc = run_process("saliency", SRC, "-o", tmp_path / "o.laz", "-q")  # another process than the writer
    assert proc.returncode == 0 and live.exists()
