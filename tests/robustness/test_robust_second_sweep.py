"""The defects of the second hostile sweep (issue 40): full disks when a run takes its lock, names
longer than a file system takes, numbers beyond a float, tiles asked of Pipeline.run, work
folders and locks left behind or held after a job, rows of a catalogue, messages about tiles and
workers, line breaks in file names, the sample over a folder, locks that are not files.

Each case is met as a user meets it, from a scratch folder: the command (in this process,
tests/command_line.py; in a real process where only a process shows it: a lock held by another
process) or the Python call. It must end as the project promises: exit status 2 and one line
naming the file or value and the fix (or a LidarSigError at the call), no traceback, nothing
left behind (no output, work folder, lock file or empty file), inputs untouched, and no lock
held once a job has returned or raised: a --resume or another run works right after.
(Signals at the start: test_robust_signals.py.)
"""
import os
import re
import shutil
import sys
import warnings

import numpy as np
import pytest

import lidar_sig as ls
from command_line import run, run_process
from conftest import SAMPLES, airborne_like
from robustness.helpers import assert_one_line_error, digests, fill, mounted_tmpfs, write_las

EPOCH1 = SAMPLES / "epoch1.laz"
EPOCH2 = SAMPLES / "epoch2.laz"
#: A name of 90 CJK characters: 270 bytes in UTF-8, over the 255 a file name may have.
LONG = "測" * 90
#: A sequence of digits (and commas) no message should print.
LONG_NUMBER = re.compile(r"\d[\d,]{20,}")


def everything(folder):
    """Every path under ``folder`` (hidden ones too), relative, sorted."""
    return sorted(str(p.relative_to(folder)) for p in folder.rglob("*"))


def locks(folder):
    """Lock files under ``folder``."""
    return [p for p in everything(folder) if p.endswith(".lock")]


def ten_points(path, seed=0):
    """A LAS file of 10 points: fewer than any scale needs."""
    return write_las(path, np.random.default_rng(seed).uniform(0, 10, (10, 3)))


# -- 1. a full disk when a run takes its lock ---------------------------------------------------

@pytest.mark.parametrize("args, named", [
    (lambda fs, tmp: ["catalog", EPOCH1, EPOCH2, "-o", fs / "c.h5"], "c.h5"),
    (lambda fs, tmp: ["saliency", EPOCH1, EPOCH2, "-o", fs / "out"], ".lidar-sig-work"),
    (lambda fs, tmp: ["signature", EPOCH1, EPOCH2, "-o", fs / "s.h5"], "s.h5.work"),
    (lambda fs, tmp: ["signature", EPOCH1, EPOCH2, "-o", tmp / "s.h5", "--work-dir", fs / "wd"], "wd"),
], ids=["catalog", "saliency-set", "signature-set", "work-dir"])
def test_a_full_disk_when_a_run_takes_its_lock_is_one_line_and_leaves_no_lock(tmp_path, args, named):
    # OSError: [Errno 28] from io/atomic.py hold() (exit status 1), a 0-byte lock file and an
    # output folder holding only a lock left behind
    scratch = tmp_path / "scratch"
    scratch.mkdir()
    with mounted_tmpfs(tmp_path, size="24m") as fs:  # room for the run once the filler goes
        fill(fs)
        proc = run(*args(fs, scratch), "--workers", "1", "-q")
        assert_one_line_error(proc, named, "no space left")
        assert everything(fs) == ["filler"] and everything(scratch) == []
        (fs / "filler").unlink()  # room again: the same command runs at once, no lock in its way
        again = run(*args(fs, scratch), "--workers", "1", "-q")
        assert again.returncode == 0, again.stderr
        assert locks(fs) == [] and locks(scratch) == []


def test_a_catalogue_job_on_a_full_disk_raises_a_lidar_sig_error(tmp_path):
    with mounted_tmpfs(tmp_path, size="1m") as fs:
        fill(fs)
        with pytest.raises(ls.LidarSigError, match="no space left"):
            ls.jobs.catalog([EPOCH1], fs / "c.h5", execution=ls.Execution(workers=1))
        assert everything(fs) == ["filler"]


# -- 2. names longer than a file system takes ------------------------------------------------------

@pytest.mark.parametrize("args", [
    lambda t: ["saliency", EPOCH1, "-o", t / f"{LONG}.laz"],
    lambda t: ["saliency", EPOCH1, EPOCH2, "-o", t / LONG, "--workers", "1"],
    lambda t: ["saliency", t / f"{LONG}.laz", "-o", t / "o.laz"],
    lambda t: ["info", t / f"{LONG}.laz"],
    lambda t: ["signature", EPOCH1, "-o", t / "s.h5", "--report", t / f"{LONG}.html"],
    lambda t: ["signature", EPOCH1, "--plots", t / LONG],
    lambda t: ["signature", EPOCH1, EPOCH2, "-o", t / "s.h5", "--work-dir", t / LONG, "--workers", "1"],
    lambda t: ["compare", EPOCH1, t / f"{LONG}.h5"],
    lambda t: ["changes", t / LONG, EPOCH2, "-o", t / "c.tif"],
    lambda t: ["changes", EPOCH1, EPOCH2, "-o", t / "c.tif", "--cells", t / f"{LONG}.gpkg"],
    lambda t: ["catalog", t / LONG, "-o", t / "c.h5"],
    lambda t: ["catalog", EPOCH1, "-o", t / f"{LONG}.h5"],
    lambda t: ["outliers", t / f"{LONG}.h5"],
    lambda t: ["resilience", EPOCH1, "--plot", t / f"{LONG}.png"],
    lambda t: ["sample", t / LONG],
    lambda t: ["info", t / LONG / "x.laz"],
], ids=["output", "set-output", "input", "info", "report", "plots", "work-dir", "compare", "changes-epoch",
        "cells", "catalog-input", "catalog-output", "outliers", "plot", "sample", "folder"])
def test_a_name_longer_than_the_file_system_takes_is_one_line(tmp_path, args):
    # OSError: [Errno 36] File name too long (exit status 1), from every command
    given = args(tmp_path)
    proc = run(*given) if given[0] in ("info", "sample") else run(*given, "-q")  # these two have no -q
    assert_one_line_error(proc, LONG[:10], "long", "give a shorter name")
    assert everything(tmp_path) == []


def test_a_name_with_room_for_itself_but_not_for_its_temporary_file_is_refused_before_the_work(tmp_path):
    # a name of 70 CJK characters (214 bytes) fits, but its temporary file beside it would not
    name = tmp_path / ("測" * 70 + ".laz")
    proc = run("saliency", EPOCH1, "-o", name, "-q")
    assert_one_line_error(proc, "測" * 10, "temporary file", "give a shorter name")
    assert everything(tmp_path) == []


def test_python_calls_given_a_name_too_long_raise_a_lidar_sig_error(tmp_path):
    with pytest.raises(ls.LidarSigError, match="give a shorter name"):
        ls.read(tmp_path / f"{LONG}.laz")
    with pytest.raises(ls.LidarSigError, match="give a shorter name"):
        ls.Execution(work_dir=tmp_path / LONG)
    with pytest.raises(ls.LidarSigError, match="give a shorter name"):
        ls.jobs.saliency(EPOCH1, tmp_path / f"{LONG}.laz")


# -- 4. numbers beyond a float ---------------------------------------------------------------------

@pytest.mark.parametrize("given, named", [
    (dict(memory=10**400), "memory"), (dict(tile_size=10**400), "tile_size"), (dict(memory="1e300T"), "memory"),
    (dict(memory=float("inf")), "memory"), (dict(tile_size=-(10**400)), "tile_size"),
])
def test_an_execution_given_a_number_beyond_a_float_raises_a_short_lidar_sig_error(given, named):
    # OverflowError: int too large to convert to float
    with pytest.raises(ls.LidarSigError, match=named) as caught:
        ls.Execution(**given)
    assert len(str(caught.value)) < 200 and not LONG_NUMBER.search(str(caught.value)), caught.value


@pytest.mark.parametrize("option, value", [("--memory", "1" + "0" * 400), ("--tile-size", "1e400"),
                                           ("--memory", "1e300T")])
def test_an_option_beyond_a_float_is_one_short_line(tmp_path, option, value):
    proc = run("saliency", EPOCH1, EPOCH2, "-o", tmp_path / "out", option, value, "--workers", "1")
    assert_one_line_error(proc, option)
    assert not LONG_NUMBER.search(proc.stderr) and everything(tmp_path) == []


# -- 5. Pipeline.run honours the tiles an Execution asks for -----------------------------------------

def test_pipeline_run_runs_the_tiles_an_execution_asks_for_in_its_work_folder(tmp_path):
    # tile_size, workers and work_dir were ignored: one block, in memory
    work = tmp_path / "scratch"
    work.mkdir()
    pipe = ls.Pipeline(progress=False)
    result = pipe.run(EPOCH1, execution=ls.Execution(tile_size=20, workers=1, work_dir=work))
    try:
        assert result.tiled and result.metadata["tiling"]["tile_size_m"] == 20.0
        assert result.metadata["tiling"]["n_tiles_run"] > 1
        assert [p.name.startswith("lidar-sig-work-") for p in work.iterdir()] == [True]  # its own folder
        assert locks(work) == []  # the run has returned: nothing held
        alone = pipe.run(EPOCH1)  # the same values as one block
        np.testing.assert_allclose(result.saliency.values, alone.saliency.values, rtol=0, atol=1e-9)
    finally:
        result.close()
    assert everything(work) == []


@pytest.mark.parametrize("work_dir, named", [
    (lambda t: t / "afile", "is a file"),
    (lambda t: t / "afile" / "sub", "is a file"),
    (lambda t: "/proc/lidar-sig-work", "/proc/lidar-sig-work"),
    (lambda t: "/proc", "/proc"),
    (lambda t: t / "missing", "does not exist"),
])
def test_pipeline_run_refuses_a_work_folder_it_cannot_use_in_one_lidar_sig_error(tmp_path, work_dir, named):
    (tmp_path / "afile").write_text("x")
    execution = ls.Execution(tile_size=20, workers=1, work_dir=work_dir(tmp_path))
    with pytest.raises(ls.LidarSigError, match=named) as caught:
        ls.Pipeline(progress=False).run(EPOCH1, execution=execution)
    assert "work_dir" in str(caught.value) and "\n" not in str(caught.value)
    assert everything(tmp_path) == ["afile"]


def test_pipeline_run_refuses_a_read_only_work_folder_in_one_lidar_sig_error(tmp_path):
    with mounted_tmpfs(tmp_path, size="1m", read_only=True) as fs:
        with pytest.raises(ls.LidarSigError, match="work_dir"):
            ls.Pipeline(progress=False).run(EPOCH1, execution=ls.Execution(tile_size=20, workers=1, work_dir=fs))


def test_pipeline_run_refuses_tiles_of_points_given_in_memory():
    xyz, labels = airborne_like(600)
    with pytest.raises(ls.LidarSigError, match="LAS/LAZ file.*tile_size"):
        ls.Pipeline(progress=False).run(ls.PointCloud(xyz, labels), execution=ls.Execution(tile_size=20))


# -- 6, 7, 15. work folders and locks after a job -------------------------------------------------

@pytest.fixture
def one_unreadable(tmp_path):
    """A folder of the sample's first epoch and a LAS file cut short."""
    folder = tmp_path / "tiles"
    folder.mkdir()
    shutil.copyfile(EPOCH1, folder / "epoch1.laz")
    (folder / "cut.laz").write_bytes(EPOCH2.read_bytes()[:5000])
    return folder


def test_a_job_that_returns_incomplete_holds_no_lock_and_a_resume_from_the_command_line_runs(
        tmp_path, one_unreadable):
    # the Python process kept the work folder locked: a --resume was told that another run works in it
    out = tmp_path / "out"
    done = ls.jobs.saliency(one_unreadable, out, execution=ls.Execution(workers=1))
    assert not done.complete and done.work and "work kept in" in done.problems()[-1]
    assert (out / ".lidar-sig-work").is_dir() and locks(tmp_path) == []
    (one_unreadable / "cut.laz").unlink()
    resumed = run_process("saliency", one_unreadable, "-o", out, "--workers", "1", "--resume", "-q")
    assert resumed.returncode == 0, resumed.stderr
    assert everything(out) == ["epoch1.laz"]  # the work folder gone with the complete run


def test_an_incomplete_run_keeps_its_work_without_its_lock(tmp_path, one_unreadable):
    proc = run("signature", one_unreadable, "-o", tmp_path / "s.h5", "--workers", "1", "-q")
    assert proc.returncode == 1 and "work kept in" in proc.stderr, proc.stderr
    assert (tmp_path / "s.h5.work").is_dir() and locks(tmp_path) == []


def test_a_job_that_raises_leaves_nothing_and_holds_nothing(tmp_path):
    # the folder of two 10-point tiles left a new output folder holding only work, and its lock
    tiles = tmp_path / "tiles"
    tiles.mkdir()
    before = digests(ten_points(tiles / "a.las", 1), ten_points(tiles / "b.las", 2))
    with pytest.raises(ls.LidarSigError, match="fewer than the largest scale needs"):
        ls.jobs.signature(tiles, tmp_path / "s.h5", execution=ls.Execution(workers=1))
    proc = run("saliency", tiles, "-o", tmp_path / "out", "--workers", "1", "-q")
    assert_one_line_error(proc, "fewer than the largest scale needs")
    assert everything(tmp_path) == ["tiles", "tiles/a.las", "tiles/b.las"] and digests(*before) == before
    again = run_process("signature", EPOCH1, EPOCH2, "-o", tmp_path / "s.h5", "--workers", "1", "-q")
    assert again.returncode == 0, again.stderr  # the same work folder, free


def test_a_file_in_tiles_that_fails_with_a_user_error_leaves_no_work_folder(tmp_path):
    # `signature ten.laz -o ten.h5` in tiles left ten.h5.work/ and its lock, without saying so
    ten_points(tmp_path / "ten.las")
    proc = run("signature", tmp_path / "ten.las", "-o", tmp_path / "ten.h5", "--tile-size", "5", "--workers", "1")
    assert_one_line_error(proc, "fewer than the largest scale needs")
    assert everything(tmp_path) == ["ten.las"]


def test_a_user_error_after_the_tiles_keeps_them_and_says_so(tmp_path, monkeypatch):
    # the tiles are done and the archive cannot be written: the error says where they are kept,
    # and the same command with --resume writes it from them
    signature_job = sys.modules["lidar_sig.jobs.signature"]  # (lidar_sig.jobs.signature is the job's function)

    def no_room(*args, **kwargs):
        raise ls.LidarSigError("could not be written: no space left on the device", path=tmp_path / "s.h5")

    monkeypatch.setattr(signature_job, "_write", no_room)
    proc = run("signature", EPOCH1, EPOCH2, "-o", tmp_path / "s.h5", "--workers", "1", "-q")
    assert_one_line_error(proc, "no space left", "finished tiles are kept in", "s.h5.work", "--resume")
    assert locks(tmp_path) == []
    monkeypatch.undo()
    resumed = run("signature", EPOCH1, EPOCH2, "-o", tmp_path / "s.h5", "--workers", "1", "--resume", "-q")
    assert resumed.returncode == 0, resumed.stderr
    assert everything(tmp_path) == ["s.h5"]


def test_an_interrupted_run_keeps_its_work_without_its_lock_and_resumes(tmp_path, monkeypatch):
    from lidar_sig.tiling import run_set as tiling_run

    def interrupted(plan, ij):
        raise KeyboardInterrupt

    real = tiling_run.tile_task
    monkeypatch.setattr(tiling_run, "tile_task", interrupted)
    proc = run("saliency", EPOCH1, EPOCH2, "-o", tmp_path / "out", "--workers", "1", "-q")
    assert proc.returncode == 130 and "kept in" in proc.stderr, proc.stderr
    assert (tmp_path / "out" / ".lidar-sig-work").is_dir() and locks(tmp_path) == []
    monkeypatch.setattr(tiling_run, "tile_task", real)
    resumed = run("saliency", EPOCH1, EPOCH2, "-o", tmp_path / "out", "--workers", "1", "--resume", "-q")
    assert resumed.returncode == 0, resumed.stderr
    assert everything(tmp_path / "out") == ["epoch1.laz", "epoch2.laz"]


# -- 8. rows of a catalogue ------------------------------------------------------------------------

def test_catalogue_rows_out_of_range_are_lidar_sig_errors(tmp_path):
    # counts([-5]) returned another row's raster; counts([99]) raised IndexError
    assert run("catalog", EPOCH1, EPOCH2, "-o", tmp_path / "c.h5", "--workers", "1", "-q").returncode == 0
    cat = ls.Catalog(tmp_path / "c.h5")
    for rows in ([-5], [99], [-1], 2.5):
        for call in (cat.counts, cat.total_rasters, cat.sg):
            with pytest.raises(ls.LidarSigError, match="row|rows"):
                call(rows)
    both = cat.counts([0, "epoch2"])
    assert sorted(both) == [0, 1] and both[1].sum() == cat.signature(1).counts.sum()


# -- 9. tile sizes and workers ---------------------------------------------------------------------

def test_a_tiny_tile_size_is_told_in_a_short_line_about_what_was_given(tmp_path):
    # a 400-character tile count
    proc = run("saliency", EPOCH1, EPOCH2, "-o", tmp_path / "out", "--tile-size", "1e-300", "--workers", "1")
    assert_one_line_error(proc, "--tile-size 1e-300", "at least")
    assert len(proc.stderr) < 250 and not LONG_NUMBER.search(proc.stderr), proc.stderr
    assert everything(tmp_path) == []


def test_workers_far_above_the_cores_are_refused_naming_the_cores_not_a_tile_size(tmp_path):
    # --workers 1000 was told to give a --tile-size it never gave; up to 1024 ran on 2 cores
    proc = run("saliency", EPOCH1, EPOCH2, "-o", tmp_path / "out", "--workers", "1000")
    assert_one_line_error(proc, "--workers 1000", "cores")
    assert "tile-size" not in proc.stderr and everything(tmp_path) == []
    with pytest.raises(ls.LidarSigError, match="workers=1000.*cores"):
        ls.Execution(workers=1000)


def test_workers_above_the_cores_get_a_note():
    cores = len(os.sched_getaffinity(0))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        assert ls.Execution(workers=cores + 1).workers == cores + 1
        ls.Execution(workers=cores)
    notes = [str(w.message) for w in caught if issubclass(w.category, ls.LidarSigWarning)]
    assert len(notes) == 1 and f"{cores} cores" in notes[0], notes


def test_many_workers_without_a_tile_size_get_tiles_large_enough(tmp_path):
    # the default size, two tiles per worker, made tiles too small for 1000 workers and was refused
    from lidar_sig.tiling.backends import InProcess

    class ManyWorkers(InProcess):  # a backend said to have 1,000 workers, run in this process
        workers = 1000

    run_ = ls.run_set(ls.Pipeline(progress=False), [EPOCH1], work=tmp_path / "w", backend=ManyWorkers())
    # tiles of 250 points or more on average, not two per worker (2,000 tiles of 20 points)
    assert run_.complete and 1 < run_.tiling_record()["n_tiles_run"] <= 41507 / 250
    assert locks(tmp_path) == []


# -- 10. a catalogue's work folder on a full disk ------------------------------------------------------

def test_a_catalogue_whose_work_folder_is_full_names_the_folder_not_the_tiles(tmp_path):
    # "none of the 2 tiles could be computed (epoch1.laz: OSError: [Errno 28] ...)"
    with mounted_tmpfs(tmp_path, size="1m") as fs:
        fill(fs, leave=24_000)  # room for the work folder, not for a tile's result
        proc = run("catalog", EPOCH1, EPOCH2, "-o", tmp_path / "c.h5", "--work-dir", fs / "wd", "--workers", "1",
                   "-q")
        assert_one_line_error(proc, "wd", "work folder", "No space left", "--work-dir")
        assert "OSError" not in proc.stderr and "could be computed" not in proc.stderr
        assert everything(fs) == ["filler"]
    assert sorted(p.name for p in tmp_path.iterdir() if not p.name.startswith("fs-")) == []


# -- 11. line breaks in file names ---------------------------------------------------------------------

def test_a_line_break_in_a_file_name_does_not_split_an_error_or_a_repr(tmp_path):
    # the second line of an error read as a separate, forged error; reprs spanned lines
    bad = tmp_path / "bad\nfile.laz"
    bad.write_bytes(EPOCH1.read_bytes()[:3000])
    assert_one_line_error(run("info", bad), "bad\\nfile.laz")
    assert_one_line_error(run("info", tmp_path / "no\nsuch.laz"), "no\\nsuch.laz")
    assert_one_line_error(run("sample", tmp_path / "x\ny" / "z"), "x\\ny")
    with pytest.raises(ls.LidarSigError) as caught:
        ls.read(bad)
    assert "\n" not in str(caught.value) and caught.value.path == str(bad)  # the name as given, for programs
    good = tmp_path / "new\nline.laz"
    shutil.copyfile(EPOCH1, good)
    for shown in (ls.read(good), ls.Execution(work_dir="a\nb"),
                  ls.jobs.saliency(good, tmp_path / "out\r.laz", pipeline=ls.Pipeline(progress=False))):
        assert "\n" not in repr(shown) and "\r" not in repr(shown) and repr(shown).startswith("<"), repr(shown)


def test_a_line_break_in_a_file_name_cannot_forge_a_row_of_a_printed_table(tmp_path):
    # the tables on stdout name files, tiles and classes: each row stays one row
    forged = tmp_path / "a\n  d_BD-Img      9.9999   forged.laz"
    shutil.copyfile(EPOCH1, forged)
    proc = run("compare", forged, EPOCH2)
    assert proc.returncode == 0, proc.stderr
    lines = proc.stdout.splitlines()
    assert any(line.startswith("A ") and "a\\n  d_BD-Img      9.9999   forged.laz: " in line for line in lines), lines
    assert [line for line in lines if line.lstrip().startswith("d_BD-Img")] == [
        line for line in lines if line.startswith("  d_BD-Img ") and "9.9999" not in line]


def test_a_line_break_in_a_tile_name_keeps_each_problem_on_its_line(tmp_path):
    tiles = tmp_path / "tiles"
    tiles.mkdir()
    shutil.copyfile(EPOCH1, tiles / "epoch1.laz")
    (tiles / "cut\nlidar-sig: error: forged.laz").write_bytes(EPOCH2.read_bytes()[:5000])
    proc = run("saliency", tiles, "-o", tmp_path / "out", "--workers", "1", "-q")
    assert proc.returncode == 1, proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 2 and all(line.startswith("lidar-sig: ") for line in lines), lines
    assert not any(line.startswith("lidar-sig: error") for line in lines), lines


# -- 12. the sample over a folder or through a dangling link -------------------------------------------

def test_the_sample_where_one_of_its_files_is_a_folder_does_not_advise_overwrite(tmp_path):
    # "pass --overwrite", which then failed
    (tmp_path / "s" / "epoch1.laz").mkdir(parents=True)
    for extra in ((), ("--overwrite",)):
        proc = run("sample", tmp_path / "s", *extra)
        assert_one_line_error(proc, "epoch1.laz", "is a folder")
        assert "--overwrite" not in proc.stderr
    assert everything(tmp_path) == ["s", "s/epoch1.laz"]


def test_the_sample_into_a_dangling_link_names_the_link(tmp_path):
    # "File exists"
    (tmp_path / "s").symlink_to(tmp_path / "gone")
    proc = run("sample", tmp_path / "s")
    assert_one_line_error(proc, "s", "link", "does not exist")
    assert everything(tmp_path) == ["s"] and not (tmp_path / "gone").exists()


# -- 13. a lock that is not a file -----------------------------------------------------------------------

@pytest.mark.parametrize("make, kind", [
    (lambda lock, t: lock.mkdir(), "a folder"),
    (lambda lock, t: lock.symlink_to(t / "gone" / "x"), "a link"),
    (lambda lock, t: lock.symlink_to(t / "elsewhere"), "a link"),
])
def test_a_lock_that_is_not_a_file_is_named_and_never_followed(tmp_path, make, kind):
    # reported as a fault of the catalogue; a link to elsewhere made its target there
    make(tmp_path / ".c.h5.lock", tmp_path)
    proc = run("catalog", EPOCH1, "-o", tmp_path / "c.h5", "--workers", "1", "-q")
    assert_one_line_error(proc, ".c.h5.lock", kind, "remove it")
    assert everything(tmp_path) == [".c.h5.lock"]
    assert not (tmp_path / "elsewhere").exists()


# -- 14. messages about the work folder and the memory ---------------------------------------------------

def test_an_empty_work_dir_is_said_empty():
    # "got a str"
    with pytest.raises(ls.LidarSigError, match="work_dir must be a folder path, got an empty path"):
        ls.Execution(work_dir="")


def test_a_work_dir_under_a_file_names_the_file(tmp_path):
    # "parent folder does not exist" (it is a file)
    (tmp_path / "afile").write_text("x")
    proc = run("signature", EPOCH1, EPOCH2, "-o", tmp_path / "s.h5", "--work-dir", tmp_path / "afile" / "sub",
               "--workers", "1")
    assert_one_line_error(proc, "afile", "is a file", "--work-dir")
    assert "does not exist" not in proc.stderr and everything(tmp_path) == ["afile"]


def test_a_memory_of_terabytes_prints_in_terabytes():
    # "2.05e+03 GiB"
    assert repr(ls.Execution(memory="2TB")) == "<Execution 2 TiB per process, all cores>"


def test_an_execution_prints_like_the_other_reprs(tmp_path):
    shown = repr(ls.Execution(memory="800MiB", workers=1, tile_size=30, work_dir=tmp_path))
    assert shown == f"<Execution 800 MiB per process, 1 process, tiles of 30 m, work in {tmp_path}>"
