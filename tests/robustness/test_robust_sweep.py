"""The defects of a hostile sweep of every command (issue 34): data lost, hangs, wrong answers,
tracebacks and unclear messages. Each case is run as a user would meet it and must end as the
project promises: exit status 2 and one line naming the file or value and the fix (or a clean
run where the input is valid), no traceback, nothing half-written, inputs unchanged.

Catalogues first: two runs growing one catalogue at once (real processes), and catalogues
damaged in every way the sweep found, given to each command that reads one.
"""
import json
import os
import re
import shutil
import signal
import subprocess
import sys
import time

import h5py
import laspy
import numpy as np
import pytest

import lidar_sig as ls
from command_line import run, run_process
from conftest import DATA, SAMPLES, airborne_like, need_data
from robustness.helpers import assert_one_line_error, digests, fill, leftovers, mounted_tmpfs, write_las

#: An offset that puts the synthetic scene in Lambert-93 coordinates.
OFFSET = np.array([770500.0, 6277500.0, 0.0])
#: A sequence of digits (and commas) no message of a count should print.
LONG_NUMBER = re.compile(r"\d[\d,]{20,}")


def tile(path, seed, east=0.0, north=0.0, n=800):
    """A small airborne-like LAS tile 40 m wide, ``east`` and ``north`` metres from OFFSET."""
    xyz, labels = airborne_like(n, seed=seed)
    return write_las(path, xyz + OFFSET + [east, north, 0.0], labels)


@pytest.fixture(scope="module")
def survey(tmp_path_factory):
    """Six tiles in a 3 x 2 grid and a catalogue of the first two (copy it before changing it)."""
    folder = tmp_path_factory.mktemp("survey")
    tiles = [tile(folder / f"t{i}.las", i, 50.0 * (i % 3), 50.0 * (i // 3)) for i in range(6)]
    made = run("catalog", *tiles[:2], "-o", folder / "base.h5", "--workers", "1", "-q")
    assert made.returncode == 0, made.stderr
    return tiles, folder / "base.h5"


@pytest.fixture(scope="module")
def catalogue(survey, tmp_path_factory):
    """A catalogue of four of the tiles (copy it before changing it)."""
    tiles, _ = survey
    path = tmp_path_factory.mktemp("catalogue") / "c.h5"
    made = run("catalog", *tiles[:4], "-o", path, "--workers", "1", "-q")
    assert made.returncode == 0, made.stderr
    return path


# -- two runs growing one catalogue -------------------------------------------------------------

def _names(path):
    with h5py.File(path, "r") as f:
        return {v.decode() if isinstance(v, bytes) else str(v) for v in f["tiles/name"][()]}


@pytest.mark.parametrize("trial", range(3))
def test_two_catalog_runs_growing_one_catalogue_lose_no_tile(tmp_path, survey, trial):
    # both exited 0 and the catalogue held 4 of the 6 tiles: each wrote the tiles it had read
    # and its own, the last to finish over the other's. Now one runs; the other is refused,
    # naming the first (or, started late, grows the catalogue the first wrote)
    tiles, base = survey
    out = tmp_path / "c.h5"
    shutil.copyfile(base, out)
    groups = [tiles[2:4], tiles[4:6]]
    procs = [subprocess.Popen([sys.executable, "-m", "lidar_sig", "catalog", *map(str, group), "-o", str(out),
                               "--workers", "1", "-q"], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                              stdin=subprocess.DEVNULL) for group in groups]
    ended = []
    for proc in procs:
        out_, err = proc.communicate(timeout=300)
        ended.append((proc.returncode, out_, err))
    held = {t.name for t in tiles[:2]}
    for (status, _, err), group in zip(ended, groups):
        if status == 0:
            held |= {t.name for t in group}
        else:
            assert status == 2, err
            lines = err.strip().splitlines()
            assert len(lines) == 1 and "Traceback" not in err, err
            assert str(out) in lines[0] and "another lidar-sig run" in lines[0] and "process" in lines[0], err
    assert any(status == 0 for status, _, _ in ended), ended
    assert _names(out) == held  # every tile of every run that said it succeeded
    assert sorted(p.name for p in tmp_path.iterdir()) == ["c.h5"]  # no lock, work folder or temporary file


def test_a_catalogue_held_by_a_run_is_refused_naming_it(tmp_path, survey):
    from lidar_sig.io.atomic import exclusive_output

    tiles, base = survey
    out = tmp_path / "c.h5"
    shutil.copyfile(base, out)
    before = digests(out)
    with exclusive_output(out, "growing"):  # as a run growing it holds it
        proc = run("catalog", tiles[2], "-o", out, "--workers", "1")
    assert_one_line_error(proc, str(out), "another lidar-sig run", f"process {os.getpid()}")
    assert digests(out) == before and sorted(p.name for p in tmp_path.iterdir()) == ["c.h5"]
    with exclusive_output(out, "growing"), pytest.raises(ls.LidarSigError, match="another lidar-sig run"):
        ls.Catalog.build(tiles[2], out)


# -- a dangling link at -o --------------------------------------------------------------------------

@pytest.mark.parametrize("command", ["saliency", "signature", "changes"])
def test_a_dangling_link_at_the_output_is_not_replaced_without_overwrite(tmp_path, survey, command):
    # check_output asked exists(), false for a link to a missing file, and the link was replaced
    suffix = {"saliency": ".laz", "signature": ".h5", "changes": ".tif"}[command]
    link = tmp_path / f"out{suffix}"
    link.symlink_to(tmp_path / "missing" / f"target{suffix}")
    src = survey[0][0]
    args = [command, src, src] if command == "changes" else [command, src]
    proc = run(*args, "-o", link)
    assert_one_line_error(proc, str(link), "already exists", "--overwrite")
    assert link.is_symlink() and os.readlink(link) == str(tmp_path / "missing" / f"target{suffix}")
    assert sorted(p.name for p in tmp_path.iterdir()) == [link.name]


def test_a_dangling_link_is_replaced_with_overwrite(tmp_path, survey):
    link = tmp_path / "out.laz"
    link.symlink_to(tmp_path / "missing.laz")
    proc = run("saliency", survey[0][0], "-o", link, "--overwrite", "-q")
    assert proc.returncode == 0, proc.stderr
    assert not link.is_symlink() and len(laspy.read(link).points) == 800


# -- FIFOs ----------------------------------------------------------------------------------------

@pytest.fixture
def fifo_folder(tmp_path, survey):
    """A folder holding a tile and FIFOs named p.laz and p.h5 (and, in a folder epoch/, a tile and
    a FIFO named pipe.laz). Reading a FIFO waits for a writer: runs are child processes with a
    time limit, so that a hang fails the test."""
    if not hasattr(os, "mkfifo"):
        pytest.skip("FIFOs need a POSIX system")
    epoch = tmp_path / "epoch"
    epoch.mkdir()
    shutil.copyfile(survey[0][0], epoch / "t0.las")
    for fifo in (epoch / "pipe.laz", tmp_path / "p.laz", tmp_path / "p.h5"):
        os.mkfifo(fifo)
    return tmp_path


def test_changes_with_a_fifo_named_laz_in_a_folder_epoch_leaves_it_out(fifo_folder):
    # it blocked forever; catalog and compare leave non-regular files of a folder out
    proc = run_process("changes", "epoch", "epoch/t0.las", "-q", cwd=fifo_folder, timeout=180)
    assert proc.returncode == 0, proc.stderr
    assert "Traceback" not in proc.stderr


@pytest.mark.parametrize("args", [
    ["info", "p.laz"], ["info", "p.h5"], ["saliency", "p.laz", "-o", "o.laz"], ["compare", "p.laz", "epoch/t0.las"],
    ["compare", "p.h5", "epoch/t0.las"], ["changes", "p.laz", "epoch/t0.las"], ["signature", "p.laz", "epoch/t0.las",
                                                                               "-o", "s.h5"],
    ["catalog", "p.laz", "-o", "c.h5"], ["outliers", "p.h5"],
], ids=lambda a: " ".join(a[:2]))
def test_a_fifo_given_as_an_input_is_refused(fifo_folder, args):
    # info, saliency and changes blocked forever; a set of tiles said "no such file or folder"
    proc = run_process(*args, cwd=fifo_folder, timeout=120)
    name = args[1]
    assert_one_line_error(proc, name, "is a FIFO, not a regular file")
    assert sorted(p.name for p in fifo_folder.iterdir()) == ["epoch", "p.h5", "p.laz"]
