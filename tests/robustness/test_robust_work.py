"""Work folders of runs in tiles that cannot be made (issue 34): a read-only place, a path under a
file, /proc, a parent that does not exist, an immutable folder; a tiled output folder in a
read-only place; an interrupted run that keeps its work says where; and the Python arguments of
how a job runs are checked where they are given."""
import shutil
import subprocess

import pytest

import lidar_sig as ls
from command_line import run
from conftest import SAMPLES
from robustness.helpers import assert_one_line_error, mounted_tmpfs

EPOCH1 = SAMPLES / "epoch1.laz"
EPOCH2 = SAMPLES / "epoch2.laz"


def _set(tmp_path, *work):
    """`lidar-sig saliency` of a set of two files into tmp_path/out with ``work`` options."""
    return run("saliency", EPOCH1, EPOCH2, "-o", tmp_path / "out", "--workers", "1", *work, "-q")


def test_a_work_folder_under_a_file_is_one_line_and_leaves_no_output_folder(tmp_path):
    (tmp_path / "file").write_text("x")
    done = _set(tmp_path, "--work-dir", tmp_path / "file" / "work")
    assert_one_line_error(done, "file/work", "--work-dir")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["file"]


def test_a_work_folder_whose_parent_is_missing_is_refused_and_nothing_is_made(tmp_path):
    done = _set(tmp_path, "--work-dir", tmp_path / "nope" / "deeper")
    assert_one_line_error(done, "nope/deeper", "parent folder does not exist")
    assert list(tmp_path.iterdir()) == []


def test_a_work_folder_in_proc_is_one_line(tmp_path):
    done = _set(tmp_path, "--work-dir", "/proc/lidar-sig-work")
    assert_one_line_error(done, "/proc/lidar-sig-work", "--work-dir")
    assert list(tmp_path.iterdir()) == []


def test_a_work_folder_on_a_read_only_mount_is_one_line(tmp_path):
    with mounted_tmpfs(tmp_path, size="1m", read_only=True) as fs:
        done = _set(tmp_path, "--work-dir", fs / "work")
        assert_one_line_error(done, "read-only", "--work-dir")
    assert sorted(p.name for p in tmp_path.iterdir() if not p.name.startswith("fs-")) == []


def test_an_immutable_work_folder_is_one_line(tmp_path):
    work = tmp_path / "work"
    work.mkdir()
    if shutil.which("chattr") is None or subprocess.run(["chattr", "+i", str(work)], capture_output=True).returncode:
        pytest.skip("cannot make a folder immutable here (chattr +i needs root and a file system that has it)")
    try:
        done = _set(tmp_path, "--work-dir", work)
        assert_one_line_error(done, "work", "--work-dir")
    finally:
        subprocess.run(["chattr", "-i", str(work)], capture_output=True)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["work"]


def test_a_tiled_output_folder_in_a_read_only_place_is_one_line(tmp_path):
    with mounted_tmpfs(tmp_path, size="1m", read_only=True) as fs:
        done = run("saliency", EPOCH1, EPOCH2, "-o", fs / "out", "--workers", "1", "-q")
        assert_one_line_error(done, "out")
        assert "Traceback" not in done.stderr


def test_an_interrupted_set_says_where_its_work_is_kept(tmp_path, monkeypatch):
    from lidar_sig.tiling import run as tiling_run

    def interrupted(plan, ij):
        raise KeyboardInterrupt

    monkeypatch.setattr(tiling_run, "tile_task", interrupted)
    done = _set(tmp_path)
    assert done.returncode == 130, done.stderr
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and "interrupted" in lines[0] and ".lidar-sig-work for --resume" in lines[0], lines
    assert (tmp_path / "out" / ".lidar-sig-work").is_dir()


@pytest.mark.parametrize("make, named", [
    (lambda: ls.Execution(workers=0), "workers"),
    (lambda: ls.Execution(workers=2.5), "workers"),
    (lambda: ls.Execution(memory=-5), "memory"),
    (lambda: ls.Execution(memory="lots"), "memory"),
    (lambda: ls.Execution(tile_size=0), "tile_size"),
    (lambda: ls.Execution(workers=2, scheduler="tcp://x:1"), "scheduler"),
    (lambda: ls.Execution(work_dir=3), "work_dir"),
    (lambda: __import__("lidar_sig.tiling.backends", fromlist=["executor"]).executor(0), "workers"),
    (lambda: ls.run_set(ls.Pipeline(), [EPOCH1], work="w", memory=-5), "memory"),
    (lambda: ls.Pipeline().run(EPOCH1, execution={"memory": "1GiB"}), "execution"),
])
def test_how_a_job_runs_is_checked_where_it_is_given_naming_the_argument(make, named):
    with pytest.raises(ls.LidarSigError, match=named):
        make()
