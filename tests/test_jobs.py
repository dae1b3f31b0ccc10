"""The jobs from Python (lidar_sig.jobs): the commands' decisions and checks, made by the library
where a Python user meets them too; and what one run holds, no other run touches."""
import os
import subprocess
import sys
import time

import laspy
import numpy as np
import pytest

import lidar_sig as ls
from command_line import run
from conftest import ROOT, SAMPLES
from lidar_sig.tiling.memory import MIB, block_bytes
from robustness.helpers import assert_one_line_error

EPOCH1, EPOCH2 = SAMPLES / "epoch1.laz", SAMPLES / "epoch2.laz"
SMALL = f"{(block_bytes(41_507) - 1) // MIB}MiB"  # just below what the sample needs as one block


def test_the_saliency_job_writes_one_file_as_the_command_does(tmp_path):
    done = ls.jobs.saliency(EPOCH1, tmp_path / "py.laz")
    assert done.complete and done.written == [str(tmp_path / "py.laz")] and done.result.metadata["n_points"] == 41_507
    assert run("saliency", EPOCH1, "-o", tmp_path / "cli.laz", "-q").returncode == 0
    a, b = laspy.read(tmp_path / "py.laz"), laspy.read(tmp_path / "cli.laz")
    assert np.array_equal(np.asarray(a["Cl"]), np.asarray(b["Cl"]), equal_nan=True)
    with pytest.raises(ls.LidarSigError, match="overwrite=True"):
        ls.jobs.saliency(EPOCH1, tmp_path / "py.laz")


@pytest.mark.parametrize("call, named", [
    (lambda tmp: ls.jobs.saliency(EPOCH1, None), "output"),
    (lambda tmp: ls.jobs.saliency([], tmp / "x.laz"), "sources"),
    (lambda tmp: ls.jobs.changes("a.laz"), "two epochs"),
    (lambda tmp: ls.jobs.changes([EPOCH1, EPOCH2, EPOCH2], points=tmp / "p.laz"), "two epochs"),
    (lambda tmp: ls.jobs.signature(EPOCH1), "give an output"),
    (lambda tmp: ls.jobs.signature(EPOCH1, tmp / "s.tif"), ".h5"),
    (lambda tmp: ls.jobs.outliers(tmp / "missing.h5", output=tmp / "x.txt"), ".gpkg"),
])
def test_a_job_refuses_a_bad_argument_before_any_work_naming_it(tmp_path, call, named):
    with pytest.raises(ls.LidarSigError, match=named):
        call(tmp_path)
    assert list(tmp_path.iterdir()) == []


def test_compare_refuses_an_archive_made_otherwise_than_the_pipeline_given(tmp_path):
    assert run("signature", EPOCH1, "-o", tmp_path / "a.h5", "-q").returncode == 0
    other = ls.Pipeline("t3dvt", scales=ls.knn(10, 15), progress=False)
    with pytest.raises(ls.LidarSigError, match="another method.*leave out pipeline"):
        ls.compare(EPOCH2, tmp_path / "a.h5", pipeline=other)
    assert ls.compare(EPOCH2, tmp_path / "a.h5").method["descriptor"] == "c3dcm"  # no pipeline: the archive's way


def test_a_work_folder_is_used_by_one_run_at_a_time(tmp_path):
    # a second run in the same work folder would have emptied it under the first
    work = tmp_path / "work"
    holder = subprocess.Popen([sys.executable, "-c", "import sys, time\nfrom lidar_sig.tiling.work import prepare_work\n"
                               f"prepare_work({str(work)!r}, False)\nprint('held', flush=True)\ntime.sleep(60)\n"],
                              stdout=subprocess.PIPE, text=True, env=dict(os.environ, PYTHONPATH=str(ROOT)))
    try:
        assert holder.stdout.readline().strip() == "held"
        done = run("saliency", EPOCH1, "-o", tmp_path / "out.laz", "--memory", SMALL, "--work-dir", work)
        assert_one_line_error(done, "work", "another lidar-sig run is working in it", f"process {holder.pid}")
        assert not (tmp_path / "out.laz").exists()
    finally:
        holder.kill()
        holder.wait()
    time.sleep(0.1)  # the system lets go of the lock with the process
    done = run("saliency", EPOCH1, "-o", tmp_path / "out.laz", "--memory", SMALL, "--work-dir", work, "-q")
    assert done.returncode == 0, done.stderr


def test_python_shows_no_progress_lines_off_a_terminal_and_the_command_does():
    env = {k: v for k, v in os.environ.items() if k != "LIDAR_SIG_PROGRESS"}
    env["PYTHONPATH"] = str(ROOT)
    script = subprocess.run([sys.executable, "-c", f"import lidar_sig as ls\nls.Pipeline().run({str(EPOCH2)!r})\n"],
                            capture_output=True, text=True, env=env, timeout=600)
    assert script.returncode == 0 and "lidar-sig: progress:" not in script.stderr, script.stderr
    command = subprocess.run([sys.executable, "-m", "lidar_sig", "compare", EPOCH1, EPOCH2], capture_output=True,
                             text=True, env=env, timeout=600)
    assert command.returncode == 0 and "lidar-sig: progress: neighbourhoods: 100%" in command.stderr


def test_the_sample_in_a_folder_that_cannot_be_made_is_one_line():
    assert_one_line_error(run("sample", "/proc/lidar-sig-sample"), "/proc/lidar-sig-sample")
