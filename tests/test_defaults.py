"""The defaults measure the land, not the survey (issue 8): rotation, unit, extent, sampling,
duplicate points; compare makes both sides the same way and warns only when something is off."""
import json

import laspy
import numpy as np
import pyproj
import pytest

import lidar_sig as ls
from command_line import run
from conftest import DATA, IGN, SAMPLES, airborne_like, need_data

TILE = IGN / "test_data_77060_627760_LA93_IGN69.laz"
FTUS = 1200.0 / 3937.0  # metres per US survey foot


def rotate_z(xyz, degrees):
    a = np.radians(degrees)
    rot = np.array([[np.cos(a), -np.sin(a), 0], [np.sin(a), np.cos(a), 0], [0, 0, 1]])
    centre = (xyz.min(axis=0) + xyz.max(axis=0)) / 2
    return (xyz - centre) @ rot.T + centre


def test_rotated_ign_tile_gives_the_same_saliency_and_class_counts(default_run):
    a = default_run(TILE)
    cloud = a.cloud
    turned = ls.PointCloud(rotate_z(cloud.xyz, 30.0), cloud.labels, crs=cloud.crs)
    b = ls.Pipeline().run(turned)
    assert a.metadata["n_undefined"] == b.metadata["n_undefined"] == 0
    # rotating Lambert-93 coordinates (northings of 6.3e6 m) rounds them to about 1e-9 m, which
    # moves a saliency over decimetre neighbourhoods by about 1e-8 at most
    np.testing.assert_allclose(a.saliency.values, b.saliency.values, rtol=0, atol=1e-7)
    assert np.array_equal(a.signature.class_totals, b.signature.class_totals)
    out = ls.compare(a.signature, b.signature)
    assert out["kl"] == out["l1"] == 0.0 and out["emd_info"] < 1e-6 and out["fv"] < 1e-3


def _write_copy(src, path, crs, metres_per_unit):
    """The points of ``src`` in another unit: the same integer records with the scales and
    offsets divided by ``metres_per_unit``, so both files hold the same places."""
    las = laspy.read(src)
    header = laspy.LasHeader(point_format=las.header.point_format.id, version="1.4")
    header.scales = las.header.scales / metres_per_unit
    header.offsets = las.header.offsets / metres_per_unit
    header.add_crs(pyproj.CRS.from_epsg(crs))
    out = laspy.LasData(header)
    out.X, out.Y, out.Z = las.X, las.Y, las.Z
    out.classification = las.classification
    out.write(path)
    return path


@pytest.fixture(scope="module")
def feet_and_metres(tmp_path_factory):
    folder = tmp_path_factory.mktemp("units")
    src = need_data(TILE)
    # NAD83 / Massachusetts Mainland, in US survey feet (EPSG:2249) and in metres (EPSG:26986):
    # only the unit matters here
    return (_write_copy(src, folder / "feet.las", 2249, FTUS), _write_copy(src, folder / "metres.las", 26986, 1.0))


def test_units_come_from_the_crs(feet_and_metres):
    feet, metres = (ls.read(p) for p in feet_and_metres)
    assert feet.units.horizontal == pytest.approx(FTUS) and feet.units.known
    assert "US survey foot" in feet.units.describe()
    assert metres.units.horizontal == 1.0 and metres.units.known
    np.testing.assert_allclose(feet.xyz * FTUS, metres.xyz, rtol=1e-12)


@pytest.mark.parametrize("options", [[], ["--units", "metric", "--radii", "1.0,1.1,1.2"]], ids=["defaults", "metric radii"])
def test_feet_file_and_its_metre_copy_give_the_same_saliency(feet_and_metres, tmp_path, options):
    outs = []
    for src in feet_and_metres:
        out = tmp_path / (src.stem + "_sal.las")
        proc = run("saliency", src, "-o", out, "-q", *options)
        assert proc.returncode == 0, proc.stderr
        outs.append(laspy.read(out))
    for dim in ("Cl", "Cs", "Cp", "Egeom"):
        a, b = (np.asarray(o[dim], dtype=np.float64) for o in outs)
        assert np.isnan(a).sum() == np.isnan(b).sum()
        np.testing.assert_allclose(a, b, rtol=0, atol=1e-6, err_msg=dim)
    assert np.array_equal(np.asarray(outs[0]["GeomClass"]), np.asarray(outs[1]["GeomClass"]))


def test_metric_radii_are_metres_in_a_feet_file(feet_and_metres):
    proc = run("compare", *feet_and_metres, "--json", "--units", "metric", "--radii", "1.0,1.1,1.2")
    assert proc.returncode == 0, proc.stderr
    out = json.loads(proc.stdout)
    assert out["a"]["scales"] == out["b"]["scales"] == [1.0, 1.1, 1.2] and out["a"]["scales_unit"] == "m"
    assert "US survey foot" in out["a"]["units"]
    assert out["fv"] < 1e-3 and out["emd_info"] < 1e-4
    # the paper's normalized radii: the same place in another unit gets the same metric radii,
    # so no warning that the extents differ
    paper = run("compare", *feet_and_metres, "--json", "--units", "normalized", "--radii", "0.009,0.010,0.011")
    out = json.loads(paper.stdout)
    assert out["a"]["scales"] == pytest.approx(out["b"]["scales"])
    assert not any("normalized radii" in w for w in out["warnings"]) and "normalized radii" not in paper.stderr


def test_geographic_crs_is_refused_with_one_line(tmp_path):
    header = laspy.LasHeader(point_format=6, version="1.4")
    header.scales = [1e-7, 1e-7, 0.01]
    header.add_crs(pyproj.CRS.from_epsg(4326))
    las = laspy.LasData(header)
    xyz = np.random.default_rng(0).uniform([3.8, 43.6, 0], [3.801, 43.601, 10], (500, 3))
    las.x, las.y, las.z = xyz.T
    las.write(tmp_path / "lonlat.las")
    proc = run("saliency", tmp_path / "lonlat.las", "-o", tmp_path / "o.las")
    assert proc.returncode == 2 and len(proc.stderr.strip().splitlines()) == 1
    assert "geographic" in proc.stderr and "reproject" in proc.stderr and not (tmp_path / "o.las").exists()


SHARED = sorted(p for p in DATA.glob("*/*.laz")) if DATA.exists() else []


@pytest.mark.parametrize("path", SHARED or [DATA / "missing.laz"], ids=lambda p: p.name)
def test_defaults_leave_fewer_than_5_percent_undefined(default_run, path):
    result = default_run(path)
    assert result.metadata["n_undefined"] < 0.05 * result.metadata["n_points"]


def test_duplicate_points_are_one_location():
    xyz, labels = airborne_like(3000, seed=11)
    once = ls.Pipeline().run(xyz, labels=labels)
    five = ls.Pipeline().run(np.repeat(xyz, 5, axis=0), labels=np.repeat(labels, 5))
    assert five.metadata["n_duplicates"] == 4 * len(xyz)
    np.testing.assert_allclose(five.saliency.values, np.repeat(once.saliency.values, 5, axis=0), atol=1e-12)
    out = ls.compare(once.signature, five.signature)
    assert out["ssim"] == 1.0 and out["fv"] < 1e-12 and out["emd_info"] < 1e-12


def test_quantized_cloud_gives_the_same_saliency_in_any_point_order():
    # LAS coordinates are integers: distances tie, and every tie with the k-th neighbour joins
    xyz, labels = airborne_like(4000, seed=12, quantum=0.01)
    order = np.random.default_rng(5).permutation(len(xyz))
    a = ls.Pipeline().run(xyz, labels=labels)
    b = ls.Pipeline().run(xyz[order], labels=labels[order])
    np.testing.assert_allclose(a.saliency.values[order], b.saliency.values, rtol=0, atol=1e-12)


def test_semantic_metrics_count_every_labelled_point():
    # small radii leave many points undefined; the class shares must not depend on which
    cloud = ls.read(need_data(TILE))
    result = ls.Pipeline(scales=ls.radii(0.25, units="metric")).run(cloud)
    assert result.metadata["n_undefined"] > 0.05 * len(cloud)
    totals = result.signature.class_totals
    assert totals.sum() == len(cloud)
    assert np.array_equal(totals, np.bincount(ls.ASPRS.index(cloud.labels), minlength=len(ls.ASPRS)))


def _archive(tmp_path, name, *options):
    path = tmp_path / name
    proc = run("signature", SAMPLES / "epoch1.laz", "-o", path, "-q", *options)
    assert proc.returncode == 0, proc.stderr
    return path


def test_compare_refuses_archives_made_with_different_methods(tmp_path, epoch1_archive):
    default = epoch1_archive
    for name, options, what in (("optimal.h5", ["--strategy", "optimal"], "strategy"),
                                ("k.h5", ["--k", "10,20"], "scale values"),
                                ("paper.h5", ["--weights", "none"], "weights"),
                                ("noise.h5", ["--keep-noise"], "keep noise")):
        other = _archive(tmp_path, name, *options)
        proc = run("compare", default, other)
        assert proc.returncode == 2, proc.stderr
        lines = proc.stderr.strip().splitlines()
        assert len(lines) == 1 and what in lines[0] and "Traceback" not in proc.stderr


def test_cloud_compared_with_an_archive_is_computed_the_archive_way(tmp_path):
    archive = _archive(tmp_path, "optimal.h5", "--strategy", "optimal", "--weights", "none")
    out = json.loads(run("compare", archive, SAMPLES / "epoch1.laz", "--json").stdout)
    # exactly: the cloud computed the archive's way on the same machine gives the archived signature
    assert out["ssim"] == 1.0 and out["fv"] == out["emd_info"] == out["kl"] == 0.0
    assert out["method"]["strategy"] == "optimal" and out["method"]["weights"] == "none"
    assert out["a"]["kind"] == "archive" and out["b"]["kind"] == "cloud"
    clash = run("compare", archive, SAMPLES / "epoch1.laz", "--strategy", "multiscale")
    assert clash.returncode == 2 and "archive made with another method" in clash.stderr


def test_compare_warns_about_undefined_points_and_foreign_classes():
    west, delft = need_data(IGN / "test_data_77055_627760_LA93_IGN69.laz"), need_data(DATA / "ahn3_delft" / "ahn3_cropped_2.laz")
    proc = run("compare", west, delft, "--json", "--units", "metric", "--radii", "0.3")
    assert proc.returncode == 0, proc.stderr
    warnings = json.loads(proc.stdout)["warnings"]
    assert any("no defined saliency" in w and "larger scales" in w for w in warnings)
    assert any("classified differently" in w for w in warnings)  # IGN vegetation 3-5, AHN3 has none
    quiet = run("compare", west, IGN / "test_data_77060_627760_LA93_IGN69.laz", "--json")
    assert json.loads(quiet.stdout)["warnings"] == [] and quiet.stderr == ""
