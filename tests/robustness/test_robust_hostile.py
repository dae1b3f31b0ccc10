"""Hostile inputs (issue 16): coordinates too large to measure in, archives whose parts disagree,
messages that said the wrong thing or nothing.

Each is refused in one line naming the file or option and the fix (exit status 2, or a
LidarSigError in Python), no traceback, nothing written.
"""
import os
import signal
import struct
import subprocess
import sys
import time

import laspy
import numpy as np
import pytest

import lidar_sig as ls
from conftest import SAMPLES
from lidar_sig.method.crs import Units
from command_line import run
from robustness.helpers import assert_one_line_error, leftovers, write_las

RNG = np.random.default_rng(16)
SMALL = RNG.uniform(0, 20, (200, 3))


# -- item 1: finite but huge coordinates -------------------------------------------------------

@pytest.mark.parametrize("xyz", [SMALL * 1e199, SMALL + 1e300, np.vstack([SMALL, [[1e200, 0.0, 0.0]]]),
                                 SMALL + [0.0, 0.0, -2e9]],
                         ids=["1e200 everywhere", "1e300 offset", "one point at 1e200", "z at -2e9"])
def test_huge_coordinates_are_refused_where_the_cloud_is_made(xyz):
    # the pipeline raised IndexError in the voxel grid (or counted the points as one location)
    with pytest.raises(ls.LidarSigError, match=r"1e\+09 m"):
        ls.Pipeline().run(xyz)
    with pytest.raises(ls.LidarSigError, match="huge.xyz"):
        ls.PointCloud(xyz, path="huge.xyz")


def test_huge_coordinates_are_measured_in_metres():
    # 4e8 US survey feet are 1.2e8 m: inside; 4e6 km are 4e9 m: outside
    feet = ls.PointCloud(SMALL + 4e8, crs="EPSG:2263")  # NAD83 / New York Long Island (ftUS)
    assert feet.units.horizontal < 0.31
    kilometres = Units(1000.0, 1000.0, "kilometre", True)
    with pytest.raises(ls.LidarSigError, match=r"1e\+09 m"):
        ls.PointCloud(SMALL + 4e6, units=kilometres)


@pytest.mark.parametrize("offset", [[4.2e6, 0.3e6, 4.7e6], [6.5e5, 6.86e6, 0.0], [5e5, 1e7, 0.0]],
                         ids=["ECEF", "Lambert-93", "UTM south"])
def test_coordinates_of_real_grids_pass(offset):
    result = ls.Pipeline(scales=ls.knn(10), progress=False).run(SMALL + offset)
    assert result.metadata["n_undefined"] == 0


def test_huge_text_coordinates_are_one_line_for_saliency_and_info(tmp_path):
    src = tmp_path / "huge.xyz"
    np.savetxt(src, SMALL * 1e199)
    out = tmp_path / "o.laz"
    for args in (("saliency", src, "-o", out), ("info", src)):
        proc = run(*args)
        assert_one_line_error(proc, "huge.xyz", "1e+09 m")
    assert not out.exists() and not leftovers(tmp_path)


def test_huge_coordinates_in_a_set_of_tiles_fail_their_file(tmp_path):
    # a set's extent came from the headers: 28 million tiles of 7e-7 m were refused, blaming
    # --tile-size; points beyond what the header says were staged as they were
    huge = write_las(tmp_path / "huge.las", SMALL + [1e200, 0.0, 0.0])
    run_ = ls.run_set(ls.Pipeline(progress=False), [huge], work=tmp_path / "w1")
    assert "1e+09 m" in run_.failed_sources[str(huge)] and run_.signature is None
    # the same points under a header whose bounds say 0 to 20 m (LAS 1.4: max x at byte 179,
    # then min x, max y, min y, max z, min z)
    raw = bytearray(huge.read_bytes())
    struct.pack_into("<6d", raw, 179, 20.0, 0.0, 20.0, 0.0, 20.0, 0.0)
    lies = tmp_path / "lies.las"
    lies.write_bytes(bytes(raw))
    run_ = ls.run_set(ls.Pipeline(progress=False), [lies], work=tmp_path / "w2")
    assert "1e+09 m" in run_.failed_sources[str(lies)] and "index 0" in run_.failed_sources[str(lies)]


# -- item 2: archives whose parts disagree with their totals ------------------------------------

@pytest.fixture(scope="module")
def archive(tmp_path_factory):
    """A small labelled archive (300 points, k 10), without per-point datasets."""
    path = tmp_path_factory.mktemp("archive") / "intact.h5"
    labels = RNG.choice([2, 6], len(SMALL))
    ls.Pipeline(scales=ls.knn(10), progress=False).run(SMALL, labels=labels).write(path, points=False)
    return path


def _edited(archive, tmp_path, name, edit):
    import h5py

    path = tmp_path / name
    path.write_bytes(archive.read_bytes())
    with h5py.File(path, "r+") as f:
        edit(f)
    return path


def _zero(dataset):
    def edit(f):
        f[dataset][...] = 0
    return edit


DISAGREEING = {
    "zero Egeom histogram": ("signature/egeom_histogram", "Egeom histogram"),
    "zero count raster": ("signature/counts", "count raster"),
    "zero class totals": ("signature/class_totals", "class totals"),
}


@pytest.mark.parametrize("case", sorted(DISAGREEING))
def test_archive_whose_parts_disagree_is_refused_when_loaded(archive, tmp_path, case):
    dataset, named = DISAGREEING[case]
    path = _edited(archive, tmp_path, "a.h5", _zero(dataset))
    with pytest.raises(ls.LidarSigError, match=named) as caught:
        ls.load_signature(path)
    assert str(caught.value).startswith(f"{path}: ") and "make it again" in str(caught.value)


def test_archive_whose_recorded_totals_disagree_is_refused(archive, tmp_path):
    for attr, value in (("n_points", 299), ("n_undefined", 7)):
        path = _edited(archive, tmp_path, f"{attr}.h5", lambda f: f.attrs.__setitem__(attr, value))
        with pytest.raises(ls.LidarSigError, match=attr):
            ls.load_signature(path)
    path = _edited(archive, tmp_path, "undefined.h5", lambda f: f["signature"].attrs.__setitem__("n_undefined", 5))
    with pytest.raises(ls.LidarSigError, match="undefined"):
        ls.load_signature(path)


def test_intact_archive_still_loads_and_compares_exactly(archive):
    sig = ls.load_signature(archive)
    assert sig.n_points == len(SMALL) and int(sig.egeom_counts.sum()) == len(SMALL)
    # exact: a signature compared with itself gives distances of exactly 0 on every CPU
    metrics = ls.compare(sig, ls.load_signature(archive))
    assert metrics["l1"] == 0 and metrics["kl"] == 0


@pytest.mark.parametrize("dataset", ["signature/egeom_histogram", "signature/counts"])
def test_compare_and_info_refuse_a_zeroed_archive_in_one_line(archive, tmp_path, dataset):
    # a zeroed Egeom histogram: compare ended with a traceback, info said nothing; a zeroed count
    # raster: compare compared an empty signature, exit 0
    path = _edited(archive, tmp_path, "zeroed.h5", _zero(dataset))
    for args in (("compare", path, archive), ("info", path)):
        assert_one_line_error(run(*args), "zeroed.h5", "make it again")


def test_archive_lacking_a_part_says_which_in_our_words(archive, tmp_path):
    # the message pasted h5py's: archive lacks "Unable to synchronously open object (object
    # 'counts' doesn't exist)"
    path = _edited(archive, tmp_path, "a.h5", lambda f: f["signature"].__delitem__("counts"))
    with pytest.raises(ls.LidarSigError) as caught:
        ls.load_signature(path)
    message = str(caught.value)
    assert "signature/counts" in message and "make it again" in message
    assert "Unable" not in message and "synchronously" not in message and "doesn't exist" not in message


# -- item 3: a signal once the output has replaced the old one -----------------------------------

def _interruptible():
    # a background job starts with SIGINT ignored: give the child a terminal's disposition
    signal.signal(signal.SIGINT, signal.SIG_DFL)


@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM])
def test_signal_once_the_output_is_in_place_is_said_or_comes_too_late(tmp_path, signum):
    # the interpreter's shutdown (0.15 to 0.4 s, after the command had ended) ran no handler: a
    # signal then ended the process by itself, status -2 or -15 and no message, although the new
    # output had replaced the old one
    out = tmp_path / "o.las"
    out.write_bytes(b"previous")
    before = os.stat(out).st_ino
    proc = subprocess.Popen([sys.executable, "-m", "lidar_sig", "saliency", SAMPLES / "epoch1.laz", "-o", out,
                             "--overwrite", "-q"], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            stdin=subprocess.DEVNULL, preexec_fn=_interruptible)
    end = time.monotonic() + 120
    while proc.poll() is None and os.stat(out).st_ino == before and time.monotonic() < end:
        time.sleep(0.001)
    proc.send_signal(signum)  # nothing is sent once the process has ended
    _, err = proc.communicate(timeout=60)
    assert len(laspy.read(out).points) == 41507 and not leftovers(tmp_path)
    if proc.returncode == 0:  # the process had ended before the signal
        assert err == ""
    else:
        assert proc.returncode == 128 + signum, (proc.returncode, err)
        lines = err.strip().splitlines()
        assert len(lines) == 1 and signal.Signals(signum).name in lines[0] and "whole" in lines[0], err


@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM])
def test_signal_as_the_command_ends_is_one_line_and_its_status(signum):
    # the signal comes right after the command has printed its lines (the moment the shutdown
    # used to fill): said, status 128 + the signal, no traceback
    code = ("import os, sys\n"
            "import lidar_sig.cli\n"
            "command = lidar_sig.cli.main\n"
            "def ended(argv=None):\n"
            "    status = command(argv)\n"
            f"    os.kill(os.getpid(), {int(signum)})\n"
            "    return status\n"
            "lidar_sig.cli.main = ended\n"
            "sys.argv = ['lidar-sig', 'plugins']\n"
            "from lidar_sig.__main__ import main\n"
            "main()\n"
            "print('main returned')\n")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120,
                          stdin=subprocess.DEVNULL, preexec_fn=_interruptible)
    assert_one_line_error(proc, f"interrupted ({signal.Signals(signum).name})", "whole", status=128 + signum)
    assert "c3dcm" in proc.stdout and "main returned" not in proc.stdout


def test_main_in_this_process_puts_the_callers_signal_handlers_back(capsys):
    from lidar_sig.__main__ import main

    before = [signal.getsignal(s) for s in (signal.SIGINT, signal.SIGTERM)]
    assert main(["plugins"]) == 0
    assert [signal.getsignal(s) for s in (signal.SIGINT, signal.SIGTERM)] == before
    assert "c3dcm" in capsys.readouterr().out


def test_interrupt_after_an_output_was_written_names_it(tmp_path, monkeypatch, capsys):
    # the line said "outputs not written, earlier ones left as they were" of an output in place
    import lidar_sig.cli.saliency
    from lidar_sig.cli import main
    from lidar_sig.base.errors import Interrupted

    def signalled(*args, **kwargs):  # SIGTERM while the summary is printed, after the write
        raise Interrupted(signal.SIGTERM)

    monkeypatch.setattr(lidar_sig.cli.saliency, "show", signalled)
    src = write_las(tmp_path / "c.las", SMALL)
    out = tmp_path / "o.las"
    assert main(["saliency", str(src), "-o", str(out), "--k", "10"]) == 128 + signal.SIGTERM
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and "SIGTERM" in lines[0] and f"written whole before it: {out}" in lines[0], lines
    assert len(laspy.read(out).points) == len(SMALL)


# -- item 4: messages --------------------------------------------------------------------------

def test_ragged_text_file_says_which_line_has_how_many_columns(tmp_path):
    # numpy's advice came through: "... use `usecols` to select a subset and avoid this error"
    src = tmp_path / "ragged.xyz"
    src.write_text("# x y z\n1 2 3\n4 5 6\n\n7 8\n1 1 1\n")
    with pytest.raises(ls.LidarSigError) as caught:
        ls.read(src)
    message = str(caught.value)
    assert "ragged.xyz" in message and "line 5 has 2 columns" in message and "3" in message
    assert "usecols" not in message


@pytest.mark.parametrize("content", [bytes(np.random.default_rng(7).integers(0, 256, 5000, dtype=np.uint8)), b""],
                         ids=["random bytes", "empty file"])
def test_pcd_that_is_not_pcd_is_said_so(tmp_path, content):
    # it was "holds no points (no positions)"
    pytest.importorskip("open3d", reason="PCD files are read through Open3D (the formats extra)")
    src = tmp_path / "noise.pcd"
    src.write_bytes(content)
    with pytest.raises(ls.LidarSigError, match="not a PCD file") as caught:
        ls.read(src)
    assert "noise.pcd" in str(caught.value) and "no positions" not in str(caught.value)


def test_saliency_of_an_empty_folder_names_the_folder_not_the_output(tmp_path):
    # it said "o.laz: a set of tiles writes one file per input: give a folder as -o"
    empty = tmp_path / "empty"
    empty.mkdir()
    proc = run("saliency", empty, "-o", tmp_path / "o.laz")
    assert_one_line_error(proc, str(empty), "holds no")
    assert "o.laz" not in proc.stderr and sorted(p.name for p in tmp_path.iterdir()) == ["empty"]


def test_k_below_min_neighbors_speaks_of_points_not_metres():
    # "every neighbourhood at k 2 (= 2 m) holds fewer than 3 points"; such a k is now refused before
    # the run (issue 34), in points
    with pytest.raises(ls.LidarSigError, match="k = 2 is below min_neighbors") as caught:
        ls.Pipeline(scales=ls.knn(2), progress=False).run(SMALL)
    message = str(caught.value)
    assert "3" in message and " m)" not in message and "= 2 m" not in message


@pytest.mark.parametrize("option", ["--descriptor", "--strategy", "--classes"])
def test_empty_name_options_are_refused_with_their_choices(tmp_path, option):
    # they silently took the defaults
    choices = {"--descriptor": "c3dcm", "--strategy": "multiscale", "--classes": "asprs"}[option]
    proc = run("signature", SAMPLES / "epoch1.laz", "-o", tmp_path / "s.h5", option, "")
    assert_one_line_error(proc, option, choices)
    assert not list(tmp_path.iterdir())


@pytest.mark.parametrize("fractions, named", [("1,,0.5", "empty"), ("0.5,0.5", "0.5")])
def test_fractions_with_an_empty_item_or_twice_the_same_are_refused(tmp_path, fractions, named):
    # "1,,0.5" ran as 1,0.5; "0.5,0.5" computed 0.5 twice
    proc = run("resilience", SAMPLES / "epoch1.laz", "--fractions", fractions)
    assert_one_line_error(proc, "--fractions", named)
    with pytest.raises(ls.LidarSigError, match="0.5"):
        ls.resilience(SMALL, fractions=(0.5, 0.5))


def test_counts_of_one_are_singular():
    # "1 points have NaN ...", "holds 1 distinct locations", "1 duplicate points", ...
    from lidar_sig.base.errors import counted
    from lidar_sig.pipeline.result import Result

    assert (counted(1, "point"), counted(2, "point"), counted(12345, "class", "classes")) == \
        ("1 point", "2 points", "12,345 classes")
    xyz = SMALL.copy()
    xyz[3] = np.nan
    with pytest.raises(ls.LidarSigError, match="1 point has NaN"):
        ls.PointCloud(xyz)
    with pytest.raises(ls.LidarSigError, match=r"holds 1 distinct location \(3 points\)"):
        ls.Pipeline(scales=ls.knn(3), progress=False).run(np.ones((3, 3)))
    with pytest.raises(ls.LidarSigError, match=r"holds 1 point,"):
        ls.Pipeline(scales=ls.knn(3), progress=False).run(np.ones((1, 3)))

    metadata = {"n_points": 1, "descriptor": "c3dcm", "strategy": "multiscale", "scale_kind": "knn",
                "resolved_scales": [10], "weights": "area", "units": "metre", "n_undefined": 1,
                "n_capped": 1, "max_neighbors": 512, "n_duplicates": 1}
    line = Result(None, None, metadata=metadata, make_signature=lambda: None).summary("c.las")
    assert "1 point," in line and "1 neighbourhood capped" in line and "1 duplicate point " in line


@pytest.mark.parametrize("command, option", [
    ("signature", "--columns"), ("signature", "--report"), ("signature", "--plots"), ("signature", "--png"),
    ("signature", "--sg"), ("signature", "--work-dir"), ("signature", "--scheduler"), ("resilience", "--plot")])
def test_other_empty_option_values_are_refused(tmp_path, capsys, command, option):
    # each was taken as not given: no report, the default work folder, local workers, ...
    # (in this process: the command line stops while parsing, before any work)
    from lidar_sig.cli import main

    out = ["-o", str(tmp_path / "s.h5")] if command == "signature" else []
    assert main([command, str(SAMPLES / "epoch1.laz"), *out, option, ""]) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and f"{option} is empty" in lines[0], lines
    assert not list(tmp_path.iterdir())
