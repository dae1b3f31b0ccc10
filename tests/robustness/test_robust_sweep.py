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

import h5py
import laspy
import numpy as np
import pytest

import lidar_sig as ls
from command_line import run, run_process
from conftest import DATA, airborne_like, need_data
from robustness.helpers import assert_one_line_error, digests, fill, mounted_tmpfs, write_las

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


# -- damaged catalogues ---------------------------------------------------------------------------

def _replace(group, name, values):
    attrs = dict(group[name].attrs)
    del group[name]
    group.create_dataset(name, data=values).attrs.update(attrs)


def _edit_spread(f, change):
    spread = json.loads(f.attrs["spread"])
    change(spread)
    f.attrs["spread"] = json.dumps(spread)


def _first(values, value):
    values = np.array(values)
    values.flat[0] = value
    return values


#: Damaged variants of a catalogue and a word the message must hold.
DAMAGE = {
    "count index out of range": (lambda f: _replace(f["tiles"], "counts_index", _first(f["tiles/counts_index"], 10**9)),
                                 "outside the count raster"),
    "count index negative": (lambda f: _replace(f["tiles"], "counts_index", _first(f["tiles/counts_index"], -1)),
                             "outside the count raster"),
    "NaN features": (lambda f: _replace(f["tiles"], "fv", _first(f["tiles/fv"], np.nan)), "column fv"),
    "NaN colours": (lambda f: _replace(f["tiles"], "color", _first(f["tiles/color"], np.nan)), "column color"),
    "zero spread": (lambda f: _edit_spread(f, lambda s: s.update(fv=0.0)), "spread of fv"),
    "infinite bounds": (lambda f: _replace(f["tiles"], "bounds", _first(f["tiles/bounds"], np.inf)), "column bounds"),
    "an Egeom column removed": (lambda f: _replace(f["tiles"], "egeom", f["tiles/egeom"][:, :-1]), "column egeom"),
    "Egeom columns changed": (lambda f: _replace(f["tiles"], "egeom", np.hstack([f["tiles/egeom"][()]] * 2)),
                              "column egeom"),
    "spread lacking a metric": (lambda f: _edit_spread(f, lambda s: s.pop("ssim")), "spread lacks the metric ssim"),
    "method not a JSON object": (lambda f: f.attrs.__setitem__("method", "[1, 2]"), "method attribute"),
    "method not JSON": (lambda f: f.attrs.__setitem__("method", "{descriptor"), "method attribute"),
    "frame size": (lambda f: f.attrs.__setitem__("frame_size", 5), "frame"),
    "negative class totals": (lambda f: _replace(f["tiles"], "class_totals", _first(f["tiles/class_totals"], -3)),
                              "negative"),
    "meta not JSON": (lambda f: _replace(f["tiles"], "meta", np.array([b"{"] * f["tiles/meta"].shape[0])),
                      "meta record"),
}


@pytest.mark.parametrize("command", ["similar", "outliers", "info", "compare", "changes"])
@pytest.mark.parametrize("damage", DAMAGE)
def test_damaged_catalogue_is_refused_naming_the_file_and_the_damage(tmp_path, catalogue, survey, damage, command):
    # rc 0 with wrong rankings and NaN distances, or KeyError / ValueError / TypeError tracebacks
    path = tmp_path / "c.h5"
    shutil.copyfile(catalogue, path)
    edit, said = DAMAGE[damage]
    with h5py.File(path, "r+") as f:
        edit(f)
    before = digests(path)
    other = survey[0][0]
    args = {"similar": ["similar", other, path], "outliers": ["outliers", path], "info": ["info", path],
            "compare": ["compare", path, other], "changes": ["changes", other, path]}[command]
    proc = run(*args, cwd=tmp_path)
    assert_one_line_error(proc, str(path), said, "the catalogue is damaged or was edited by hand")
    assert digests(path) == before and sorted(p.name for p in tmp_path.iterdir()) == ["c.h5"]


def test_damaged_catalogue_is_a_lidar_sig_error_in_python(tmp_path, catalogue):
    path = tmp_path / "c.h5"
    shutil.copyfile(catalogue, path)
    with h5py.File(path, "r+") as f:
        DAMAGE["spread lacking a metric"][0](f)
    with pytest.raises(ls.LidarSigError, match="spread lacks"):
        ls.Catalog(path)


def test_a_catalogue_is_named_as_one_where_an_archive_or_cloud_is_expected(tmp_path, catalogue, survey):
    # "is an HDF5 file but not a lidar_sig signature archive" / "is a signature archive, not a point cloud"
    other = survey[0][0]
    for args, said in ((["compare", catalogue, other], "not a signature archive"),
                       (["compare", other, catalogue], "not a signature archive"),
                       (["changes", catalogue, other], "not a point cloud")):
        proc = run(*args, cwd=tmp_path)
        assert_one_line_error(proc, str(catalogue), "is a survey catalogue", said, "lidar-sig similar")
    proc = run("info", catalogue)
    assert proc.returncode == 0 and not proc.stderr, proc.stderr
    lines = proc.stdout.splitlines()
    assert lines[0] == f"{catalogue}: lidar_sig survey catalogue, 4 tiles"
    assert [line.split(":")[0].strip() for line in lines[4:]] == [f"tile {t.name}" for t in survey[0][:4]]


def test_a_damaged_archive_frame_size_names_the_file_and_the_damage(tmp_path, epoch1_archive):
    # "signature size 5 px with margin 16 px: the size must be 16 to 4096 px ..."
    path = tmp_path / "a.h5"
    shutil.copyfile(epoch1_archive, path)
    with h5py.File(path, "r+") as f:
        f["signature"].attrs["frame_size"] = 5
    for args in (["info", path], ["compare", path, epoch1_archive]):
        assert_one_line_error(run(*args), str(path), "its frame is not one lidar_sig makes (size 5 px",
                              "the archive is damaged")


# -- CRSs written differently ---------------------------------------------------------------------

def _legacy_lambert93():
    """EPSG:2154 as a legacy WKT with TOWGS84[0,0,0,0,0,0,0] (a bound CRS once read)."""
    import pyproj

    wkt = pyproj.CRS.from_epsg(2154).to_wkt("WKT1_GDAL")
    at = wkt.index('AUTHORITY["EPSG","6171"]')  # the datum's own code, after its spheroid
    return pyproj.CRS.from_wkt(wkt[:at] + "TOWGS84[0,0,0,0,0,0,0]," + wkt[at:])


def _renamed_lambert93():
    import pyproj

    wkt = pyproj.CRS.from_epsg(2154).to_wkt()
    return pyproj.CRS.from_wkt(wkt.replace('"RGF93 v1 / Lambert-93"', '"Lambert-93 (renamed)"', 1))


def _las_in(path, crs, seed=0, east=0.0, n=3000):
    """A LAS tile of the airborne-like scene in ``crs`` (a pyproj CRS or "EPSG:n")."""
    import pyproj

    xyz, labels = airborne_like(n, seed=seed)
    header = laspy.LasHeader(point_format=6, version="1.4")
    header.offsets, header.scales = np.floor(OFFSET), [0.01] * 3
    header.add_crs(pyproj.CRS.from_user_input(crs))
    las = laspy.LasData(header)
    las.x, las.y, las.z = (xyz + OFFSET + [east, 0.0, 0.0]).T
    las.classification = labels
    las.write(path)
    return path


def test_same_crs_holds_for_the_same_crs_written_differently():
    import pyproj

    from lidar_sig.method.crs import same_crs

    modern = pyproj.CRS.from_epsg(2154)
    legacy, renamed = _legacy_lambert93(), _renamed_lambert93()
    assert legacy.is_bound and not (legacy == modern)  # pyproj alone tells them apart
    assert same_crs(modern.to_wkt(), legacy.to_wkt()) and same_crs(legacy.to_wkt(), renamed.to_wkt())
    compound = pyproj.crs.CompoundCRS("legacy + NGF", [legacy, pyproj.CRS.from_epsg(5720)])
    assert same_crs(compound.to_wkt(), pyproj.CRS("EPSG:2154+5720").to_wkt())
    assert not same_crs(legacy.to_wkt(), pyproj.CRS.from_epsg(32631).to_wkt())
    assert not same_crs(modern.to_wkt(), pyproj.CRS("EPSG:2154+5720").to_wkt())


def test_changes_and_tiled_runs_take_the_legacy_wkt_of_the_same_crs(tmp_path):
    # "a different CRS": refused by changes and by a tiled run
    legacy = _las_in(tmp_path / "legacy.las", _legacy_lambert93())
    modern = _las_in(tmp_path / "modern.las", "EPSG:2154", seed=1)
    proc = run("changes", legacy, modern, "-q")
    assert proc.returncode == 0, proc.stderr
    east = _las_in(tmp_path / "east.las", "EPSG:2154", seed=2, east=40.0)
    proc = run("signature", legacy, east, "-o", tmp_path / "set.h5", "--workers", "1", "-q")
    assert proc.returncode == 0, proc.stderr


def test_catalogue_tiles_in_one_crs_written_two_ways_are_one_survey(tmp_path):
    # grouped by the exact WKT: a name-only variant split the survey, and tiles lost their neighbours
    west = _las_in(tmp_path / "west.las", "EPSG:2154")
    east = _las_in(tmp_path / "east.las", _renamed_lambert93(), seed=1, east=40.0)
    legacy = _las_in(tmp_path / "legacy.las", _legacy_lambert93(), seed=2, east=80.0)
    proc = run("catalog", west, east, legacy, "-o", tmp_path / "c.h5", "--workers", "1")
    assert proc.returncode == 0, proc.stderr
    assert "CRSs" not in proc.stdout and "; CRS " in proc.stdout.splitlines()[0]
    found = ls.Catalog(tmp_path / "c.h5").outliers()
    assert not found.notes
    near = {r["name"]: sorted(r["neighbours"]) for r in found.results}
    assert near == {"west.las": ["east.las"], "east.las": ["legacy.las", "west.las"], "legacy.las": ["east.las"]}


def test_a_catalogue_written_with_a_crs_split_in_two_is_read_as_one(tmp_path):
    # a catalogue of an earlier version holds both texts: read, they are one CRS
    west = _las_in(tmp_path / "west.las", "EPSG:2154")
    east = _las_in(tmp_path / "east.las", "EPSG:2154", seed=1, east=40.0)
    made = run("catalog", west, east, "-o", tmp_path / "c.h5", "--workers", "1", "-q")
    assert made.returncode == 0, made.stderr
    with h5py.File(tmp_path / "c.h5", "r+") as f:
        attrs = dict(f["crs"].attrs)
        del f["crs"]
        f.create_dataset("crs", data=np.array([ls.read(west).crs, _renamed_lambert93().to_wkt()], dtype=object),
                         dtype=h5py.string_dtype()).attrs.update(attrs)
        _replace(f["tiles"], "crs", np.array([0, 1], np.int64))
    cat = ls.Catalog(tmp_path / "c.h5")
    assert len(cat.header["crs"]) == 1 and cat.columns["crs"].tolist() == [0, 0]
    assert {r["name"]: r["neighbours"] for r in cat.outliers().results} == {"west.las": ["east.las"],
                                                                            "east.las": ["west.las"]}


# -- stored images --------------------------------------------------------------------------------

def test_a_corrupted_stored_sas_image_is_flagged_by_info(tmp_path, epoch1_archive):
    # accepted silently (compare rebuilds images from the counts, so metrics stay right)
    proc = run("info", epoch1_archive)
    assert proc.returncode == 0 and not proc.stderr, proc.stderr
    assert "  stored images: Sg and Sas agree with the counts (smooth rendering)" in proc.stdout.splitlines()
    path = tmp_path / "a.h5"
    shutil.copyfile(epoch1_archive, path)
    with h5py.File(path, "r+") as f:
        f["signature/sas"][100:110, 200:210, :] = 0.0
    proc = run("info", path)
    assert proc.returncode == 0, proc.stderr
    assert "  stored images: sas differs from its counts by up to 1 (damaged or edited)" in proc.stdout.splitlines()
    notes = proc.stderr.strip().splitlines()
    assert len(notes) == 1 and notes[0].startswith(f"lidar-sig: note: {path}: its stored image sas"), proc.stderr


# -- similar ---------------------------------------------------------------------------------------

def test_similar_query_naming_a_file_is_that_file_even_with_a_tiles_name(tmp_path, catalogue, survey):
    # a file t0.las in the current folder holding t3's points: the answer was tile t0's own
    tiles, _ = survey
    shutil.copyfile(tiles[3], tmp_path / "t0.las")
    proc = run("similar", "t0.las", catalogue, "--json", "-q", cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    found = json.loads(proc.stdout)
    assert found["query"]["kind"] == "cloud"
    assert found["results"][0]["name"] == "t3.las" and found["results"][0]["distance"] == pytest.approx(0, abs=1e-9)
    # the catalogue's own file, or a name that is no file here, is the tile
    for query in (tiles[0], "t1"):
        proc = run("similar", query, catalogue, "--json", "-q", cwd=tmp_path)
        assert json.loads(proc.stdout)["query"]["kind"] == "tile", proc.stderr


def test_similar_with_an_unlabelled_text_cloud_as_query_runs_and_says_how_it_is_counted(tmp_path, catalogue,
                                                                                         survey):
    # "was made with another frame or class table ...; make it with the catalogue's settings, or give
    # the cloud" although the cloud was given
    las = laspy.read(survey[0][2])
    np.savetxt(tmp_path / "q.xyz", np.column_stack([las.x, las.y, las.z]), fmt="%.3f")
    proc = run("similar", "q.xyz", catalogue, "--top", "1", cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    assert "query q.xyz (a cloud" in proc.stdout
    notes = proc.stderr.strip().splitlines()
    assert len(notes) == 1 and "no class codes" in notes[0] and "--metric fv" in notes[0], proc.stderr
    proc = run("similar", "q.xyz", catalogue, "--top", "1", "--metric", "fv", "--json", "-q", cwd=tmp_path)
    assert json.loads(proc.stdout)["results"][0]["name"] == "t2.las"  # by geometry, its own tile


# -- text clouds written to LAS ---------------------------------------------------------------------

@pytest.mark.parametrize("unit, scale, decimals", [("degree", 1.0 / 111_000, 8), ("kilometre", 1e-3, 6)])
def test_text_cloud_in_degrees_or_km_keeps_its_resolution_in_las(tmp_path, unit, scale, decimals):
    # a fixed 0.001 scale left 3 distinct x of 3,000 points in degrees, steps of 1 m in km
    xyz, _ = airborne_like(3000)
    xyz = np.column_stack([xyz[:, :2] * scale + [3.87, 43.6], xyz[:, 2] * (scale if unit == "kilometre" else 1.0)])
    src = tmp_path / "c.xyz"
    np.savetxt(src, xyz, fmt=f"%.{decimals}f")
    given = np.loadtxt(src)
    proc = run("saliency", src, "-o", tmp_path / "o.las", "--k", "10")
    assert proc.returncode == 0 and "note" not in proc.stderr, proc.stderr
    out = laspy.read(tmp_path / "o.las")
    stored = np.column_stack([out.x, out.y, out.z])
    np.testing.assert_allclose(stored, given, rtol=0, atol=0.51 * 10.0 ** -decimals)
    assert len(np.unique(stored, axis=0)) == len(np.unique(given, axis=0))
    assert [len(np.unique(stored[:, k])) for k in range(3)] == [len(np.unique(given[:, k])) for k in range(3)]


def test_points_that_las_integers_merge_are_said(tmp_path):
    # coordinates 4,000 km apart need 1 cm steps in LAS's 32-bit integers: points 1 mm apart in x
    # merge (unless a step's boundary falls between them)
    rng = np.random.default_rng(3)
    near = np.round(rng.uniform(0, 0.5, (150, 3)), 3)
    near = np.vstack([near, near + [0.001, 0, 0]])
    xyz = np.vstack([near, near + [4e6, 0, 0]])
    src = tmp_path / "c.xyz"
    np.savetxt(src, xyz, fmt="%.3f")
    proc = run("saliency", src, "-o", tmp_path / "o.las", "--k", "10", "--weights", "none")
    assert proc.returncode == 0, proc.stderr
    notes = [line for line in proc.stderr.splitlines() if "share a location" in line]
    assert len(notes) == 1 and "0.01" in notes[0] and ".ply" in notes[0], proc.stderr


def test_copc_input_written_as_las_is_not_called_laz(tmp_path):
    # "written as plain LAZ 1.4" for a .las output
    src = need_data(DATA / "copc" / "test_data_77050_627755.copc.laz")
    proc = run("saliency", src, "-o", tmp_path / "o.las")
    assert proc.returncode == 0, proc.stderr
    notes = [line for line in proc.stderr.splitlines() if "COPC" in line]
    assert len(notes) == 1 and "LAZ" not in notes[0] and "octree index" in notes[0], proc.stderr


# -- k below min_neighbors --------------------------------------------------------------------------

@pytest.mark.parametrize("command", ["saliency", "signature", "catalog"])
def test_k_below_min_neighbors_is_refused_before_any_work(tmp_path, survey, command):
    # 99.7% of the points were left undefined without a word
    out = tmp_path / ("o.laz" if command == "saliency" else "o.h5")
    proc = run(command, survey[0][0], "-o", out, "--k", "2")
    assert_one_line_error(proc, "k = 2", "min_neighbors (3)", "--k")
    assert not list(tmp_path.iterdir())
    with pytest.raises(ls.LidarSigError, match="k = 2 is below min_neighbors"):
        ls.Pipeline(scales=ls.knn(2, 20))


# -- tiny radii, and a far outlier with radii ------------------------------------------------------

@pytest.mark.parametrize("radius", ["1e-20", "1e-100", "5e-324"])
def test_tiny_radii_end_in_one_line(tmp_path, survey, radius):
    # numpy RuntimeWarnings, then an IndexError in grid.py
    proc = run("saliency", survey[0][0], "-o", tmp_path / "o.laz", "--radii", radius)
    assert_one_line_error(proc, "t0.las", "no point has a defined saliency", "larger radii")
    assert not list(tmp_path.iterdir())


def test_a_far_outlier_does_not_change_the_other_points_radius_neighbourhoods():
    # voxel keys overflowed int64 for a box 1e7 m on every side: neighbours were missed
    xyz, _ = airborne_like(1500)
    pipe = ls.Pipeline(scales=ls.radii(1.0, 1.5), progress=False)
    alone = pipe.run(xyz).saliency
    with_outlier = pipe.run(np.vstack([xyz, [1e7, 1e7, 1e7]])).saliency
    for name in ("cl", "cs", "cp"):
        np.testing.assert_allclose(getattr(with_outlier, name)[:-1], getattr(alone, name), rtol=0, atol=1e-9)


# -- full disks --------------------------------------------------------------------------------------

def test_outliers_geopackage_on_a_full_disk_is_one_line(tmp_path, catalogue):
    # sqlite3.OperationalError: database or disk is full
    with mounted_tmpfs(tmp_path, size="64k") as fs:
        fill(fs, leave=4096)
        out = fs / "x.gpkg"
        proc = run("outliers", catalogue, "-o", out)
        assert_one_line_error(proc, str(out), "no space left")
        assert sorted(p.name for p in fs.iterdir()) == ["filler"]


def test_a_full_work_disk_in_a_tiled_run_says_so_not_that_the_input_is_unreadable(tmp_path, survey):
    # "cannot be read (6740 requested and 102 written)"
    tiles, _ = survey
    with mounted_tmpfs(tmp_path, size="256k") as fs:
        fill(fs, leave=20_000)
        proc = run("signature", tiles[0], tiles[1], "-o", tmp_path / "set.h5", "--work-dir", fs / "work",
                   "--workers", "1")
    assert proc.returncode == 1 and "Traceback" not in proc.stderr, proc.stderr
    missing = [line for line in proc.stderr.splitlines() if line.startswith("lidar-sig: missing:")]
    assert missing and all("cannot stage" in line and "No space left" in line for line in missing), proc.stderr
    assert "cannot be read" not in proc.stderr and not (tmp_path / "set.h5").exists()


# -- compare --report with an unreadable sources record -------------------------------------------

def test_compare_report_with_a_sources_record_that_is_not_json(tmp_path, epoch1_archive):
    # a JSONDecodeError traceback from reporting/provenance.py; info already said "unreadable"
    path = tmp_path / "a.h5"
    shutil.copyfile(epoch1_archive, path)
    with h5py.File(path, "r+") as f:
        f.attrs["sources"] = "not json"
    proc = run("compare", path, epoch1_archive, "--report", tmp_path / "r.html", "-q")
    assert proc.returncode == 0, proc.stderr
    assert "sources record is not the JSON list" in (tmp_path / "r.html").read_text()


# -- messages -----------------------------------------------------------------------------------------

@pytest.mark.parametrize("cell", ["1e-300", "1e12"])
def test_changes_with_an_extreme_cell_prints_short_numbers(tmp_path, survey, cell):
    # numbers of 300 and 25 digits
    src = survey[0][0]
    proc = run("changes", src, src, "--cell", cell)
    assert_one_line_error(proc, "--cell")
    assert not LONG_NUMBER.search(proc.stderr), proc.stderr


def test_columns_with_an_empty_item_are_refused(tmp_path):
    # x,,y,,z was read as x,y,z
    src = tmp_path / "c.xyz"
    np.savetxt(src, np.random.default_rng(0).uniform(0, 10, (50, 5)), fmt="%.3f")
    proc = run("info", src, "--columns", "x,,y,,z")
    assert_one_line_error(proc, "x,,y,,z", "empty item")
    with pytest.raises(ls.LidarSigError, match="empty item"):
        ls.read(src, columns="x,y,z,")


# -- Python arguments ---------------------------------------------------------------------------------

def test_python_arguments_out_of_range_are_lidar_sig_errors_naming_them(catalogue):
    # subset([-5]) and Catalog.tile(-5) wrapped round; repeats=2.7 ran twice; 'abc' a ValueError
    cloud = ls.PointCloud(airborne_like(200)[0])
    for keep in ([-5], [200], np.ones(3, bool), [[1, 2]]):
        with pytest.raises(ls.LidarSigError, match="keep"):
            cloud.subset(keep)
    assert len(cloud.subset([0, 199])) == 2 and len(cloud.subset(np.arange(200) < 10)) == 10
    cat = ls.Catalog(catalogue)
    with pytest.raises(ls.LidarSigError, match=r"no tile at row -5 .*\(rows 0 to 3\)"):
        cat.tile(-5)
    assert cat.tile(3)["name"] == "t3.las" and cat.tile("t1")["name"] == "t1.las"
    for repeats in (2.7, "abc", 0, True):
        with pytest.raises(ls.LidarSigError, match="repeats must be a whole number"):
            ls.resilience(cloud, repeats=repeats)


# -- a signal during the first EMD import ---------------------------------------------------------

def _interruptible():
    signal.signal(signal.SIGINT, signal.SIG_DFL)  # as a command typed at a terminal


def _start(*args, env=None):
    return subprocess.Popen([sys.executable, *args], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            stdin=subprocess.DEVNULL, env=env, preexec_fn=_interruptible)


def _assert_interrupted(proc, err):
    lines = [line for line in err.splitlines() if not line.startswith("import time:")]
    assert proc.returncode == 130, (proc.returncode, err[-2000:])
    assert len(lines) == 1 and lines[0].startswith("lidar-sig: interrupted (SIGINT)"), lines
    assert "Traceback" not in err and "Exception ignored" not in err


