"""Hostile inputs (issue 16): coordinates too large to measure in, archives whose parts disagree,
messages that said the wrong thing or nothing.

Each is refused in one line naming the file or option and the fix (exit status 2, or a
LidarSigError in Python), no traceback, nothing written.
"""
import struct

import numpy as np
import pytest

import lidar_sig as ls
from lidar_sig.crs import Units
from robustness.helpers import assert_one_line_error, leftovers, run, write_las

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
