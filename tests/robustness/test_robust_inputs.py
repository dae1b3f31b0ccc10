"""Hostile options and inputs (issue 9, items 7-11 and 13): bad option values, damaged or
hand-edited archives, class tables, text clouds, LAS headers that lie, third-party messages.

Each is refused (or said) in one line naming the value or file and the fix, exit status 2, no
traceback, nothing written, inputs unchanged.
"""
import json
import shutil
import struct
import tracemalloc

import h5py
import laspy
import numpy as np
import pytest

import lidar_sig as ls
from command_line import run
from conftest import SAMPLES
from robustness.helpers import assert_one_line_error, digests, leftovers, write_las

SRC = SAMPLES / "epoch1.laz"


@pytest.mark.parametrize("options,named", [
    (["--k", "nan"], "--k"), (["--k", "inf"], "--k"), (["--k", ""], "--k"), (["--k", "2.5"], "--k"),
    (["--k", "1"], "--k"), (["--radii", ""], "--radii"), (["--radii", "1e308"], "1e+308"),
    (["--radii", "-1"], "radii"), (["--radii", "a,b"], "--radii"), (["--radii", "nan"], "--radii"),
    (["--units", "metric"], "--radii"), (["--max-neighbors", "0"], "--max-neighbors"),
    (["--render", "pretty"], "--render"), (["--descriptor", "nope"], "nope"), (["--bogus"], "--bogus"),
    (["--classes", "nope"], "nope"), (["--k", "10", "--radii", "1"], "either"),
])
def test_bad_option_values_are_one_line_before_any_work(tmp_path, options, named):
    # item 7: tracebacks, silent defaults, and click's three-line usage errors
    proc = run("signature", SRC, "-o", tmp_path / "s.h5", *options)
    assert_one_line_error(proc, named)
    assert not list(tmp_path.iterdir())


def test_k_larger_than_the_cloud_is_refused(tmp_path):
    src = write_las(tmp_path / "hundred.las", np.random.default_rng(0).uniform(0, 10, (100, 3)))
    proc = run("saliency", src, "-o", tmp_path / "o.las", "--k", "3,5000")
    assert_one_line_error(proc, "hundred.las", "k = 5000")
    assert not (tmp_path / "o.las").exists()


def _edit(path, edit):
    with h5py.File(path, "r+") as f:
        edit(f)


@pytest.mark.parametrize("case", ["future version", "text version", "sources not JSON", "method not JSON",
                                  "frame against raster", "negative counts", "no counts", "class table"])
def test_damaged_archive_is_one_line(tmp_path, case, epoch1_archive):
    # item 8
    path = tmp_path / "a.h5"
    shutil.copyfile(epoch1_archive, path)
    edits = {
        "future version": lambda f: f.attrs.__setitem__("format_version", 99),
        "text version": lambda f: f.attrs.__setitem__("format_version", "two"),
        "sources not JSON": lambda f: f.attrs.__setitem__("sources", "{not json"),
        "method not JSON": lambda f: f.attrs.__setitem__("method", "[broken"),
        "frame against raster": lambda f: f["signature"].attrs.__setitem__("frame_size", 256),
        "negative counts": _negative,
        "no counts": lambda f: f["signature"].__delitem__("counts"),
        "class table": lambda f: f["signature/classes"].__delitem__("colors"),
    }
    _edit(path, edits[case])
    before = digests(path)
    for args in (("compare", path, SRC), ("info", path)):
        proc = run(*args)
        if case == "sources not JSON" and args[0] == "info":
            assert proc.returncode == 0 and "sources: unreadable" in proc.stdout, proc.stderr
            continue
        if case == "sources not JSON":
            assert proc.returncode == 0, proc.stderr  # not needed to compare
            continue
        assert_one_line_error(proc, "a.h5")
    assert digests(path) == before


def _negative(f):
    counts = f["signature/counts"][()].astype(np.int64)
    counts[0, 0, 0] = -5
    del f["signature/counts"]
    f["signature/counts"] = counts


def test_class_table_with_a_huge_code_takes_no_memory_for_it():
    # item 9: a code of 2,000,000,000 sized a dense look-up table (15.9 GB on a tile)
    table = ls.ClassTable("wide", ("ground", "far"), ((2,), (2_000_000_000,)), ((120, 90, 40), (9, 9, 9)))
    labels = np.random.default_rng(0).choice([2, 6, 2_000_000_000], 100_000)
    tracemalloc.start()
    index = table.index(labels)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    assert peak < 20 * 2**20
    assert np.array_equal(index, np.select([labels == 2, labels == 2_000_000_000], [0, 1], 2))


@pytest.mark.parametrize("codes", ["codes = true", "codes = 1099511627776", "codes = [2.5]", "codes = -1",
                                   "codes = [1, 1]", 'codes = "2"'])
def test_bad_class_table_file_is_one_line(tmp_path, codes):
    table = tmp_path / "t.toml"
    table.write_text(f'name = "t"\n[[class]]\nname = "a"\n{codes}\ncolor = [1, 2, 3]\n')
    proc = run("signature", SRC, "-o", tmp_path / "s.h5", "--classes", table)
    assert_one_line_error(proc, "t.toml")
    assert not (tmp_path / "s.h5").exists()


def test_text_labels_that_do_not_fit_las_are_refused_before_the_work(tmp_path):
    # item 10: 300 wrapped to 44 in LAS output, after the whole computation
    xyz = np.random.default_rng(1).uniform(0, 10, (200, 3))
    src = tmp_path / "t.xyz"
    np.savetxt(src, np.column_stack([xyz, np.r_[300, np.full(199, 2)]]), fmt="%.3f %.3f %.3f %d")
    assert_one_line_error(run("saliency", src, "-o", tmp_path / "o.las"), "0-255")
    assert not (tmp_path / "o.las").exists()
    assert run("saliency", src, "-o", tmp_path / "o.ply", "-q").returncode == 0  # PLY holds them
    huge = tmp_path / "huge.xyz"
    np.savetxt(huge, np.column_stack([xyz, np.r_[999999999999, np.full(199, 2)]]), fmt="%.3f %.3f %.3f %d")
    assert_one_line_error(run("saliency", huge, "-o", tmp_path / "h.ply"), "huge.xyz", "class codes")


def test_text_coordinates_far_apart_get_las_scales_that_hold_them(tmp_path):
    # item 10: an OverflowError traceback after the computation
    rng = np.random.default_rng(2)
    xyz = np.vstack([rng.uniform(0, 20, (300, 3)), rng.uniform(0, 20, (300, 3)) + [4e6, 0, 0]])
    src = tmp_path / "far.xyz"
    np.savetxt(src, xyz, fmt="%.4f")
    proc = run("saliency", src, "-o", tmp_path / "o.las", "--k", "10", "-q")
    assert proc.returncode == 0, proc.stderr
    out = laspy.read(tmp_path / "o.las")
    np.testing.assert_allclose(out.x, xyz[:, 0], atol=out.header.scales[0])


def test_las_header_counting_fewer_points_than_the_file_holds_is_said(tmp_path):
    # item 11: the output silently dropped the points past the header's count
    las = laspy.read(SRC)
    full = tmp_path / "full.las"
    las.write(full)
    raw = bytearray(full.read_bytes())
    struct.pack_into("<Q", raw, 247, len(las.points) - 1000)  # LAS 1.4 point count
    struct.pack_into("<I", raw, 107, len(las.points) - 1000)  # legacy point count
    lies = tmp_path / "lies.las"
    lies.write_bytes(bytes(raw))
    proc = run("saliency", lies, "-o", tmp_path / "o.las", "-q")
    assert proc.returncode == 0
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("lidar-sig: note:")
    assert f"{len(las.points) - 1000:,}" in lines[0] and f"{len(las.points):,}" in lines[0]


def test_damaged_ply_is_one_line_without_the_readers_own_messages(tmp_path):
    # item 13: "RPly: ..." lines came before ours
    bad = tmp_path / "bad.ply"
    bad.write_text("ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                   "property float z\nend_header\n1 2\n")
    proc = run("saliency", bad, "-o", tmp_path / "o.laz")
    assert_one_line_error(proc, "bad.ply", "cannot be read as PLY")
    assert "RPly" not in proc.stderr.split("(")[0]
    assert not leftovers(tmp_path) and not (tmp_path / "o.laz").exists()


def test_json_output_stays_one_object_with_notes_on_stderr(tmp_path):
    proc = run("compare", SRC, SAMPLES / "epoch2.laz", "--json")
    assert proc.returncode == 0 and isinstance(json.loads(proc.stdout), dict)
