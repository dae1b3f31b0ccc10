"""LAS/LAZ output (SPEC 8): LAS 1.4 originals kept bit for bit, older versions upgraded with
every value kept, saliency dimensions added once, a user's own dimensions never replaced; withheld
and noise points left out of the run but kept in the file."""
import contextlib
import datetime

import laspy
import numpy as np
import pytest

import lidar_sig as ls
from command_line import run
from conftest import DATA, IGN, IGN_FILES, NOISY, SAMPLES, airborne_like, need_data, noisy_las
from lidar_sig.base.errors import LidarSigWarning
from lidar_sig.io.fields import saliency_fields
from lidar_sig.io.las import SALIENCY_DIMS, write_las

OURS = set(SALIENCY_DIMS)
LAS12 = [DATA / "ahn3_delft" / "ahn3_cropped_1.laz", DATA / "ahn3_delft" / "ahn3_cropped_2.laz",
         DATA / "isprs_filtertest" / "CSite1_red2-utm.laz", DATA / "isprs_filtertest" / "FSite8_red1-utm.laz",
         DATA / "isprs_filtertest" / "samp11-utm.laz", DATA / "isprs_filtertest" / "samp12-utm.laz"]
COPC = DATA / "copc" / "test_data_77050_627755.copc.laz"
# EPSG code of each CRS in the data README (../shared/data/README.md); AHN3 has none in its header
README_EPSG = {"ahn3": None, "isprs": 32632}


def _saliency(n, seed=0, undefined=0.05):
    """A saliency of n points with random values, a share of them undefined."""
    rng = np.random.default_rng(seed)
    values = rng.dirichlet([1.0, 1.0, 1.0], n)
    values[rng.random(n) < undefined] = np.nan
    return ls.Saliency.from_values(values)


def _check_roundtrip(src_path, out_path, strategy):
    src = laspy.read(src_path)
    out = laspy.read(out_path)
    assert len(out.points) == len(src.points)
    for name in src.point_format.dimension_names:
        assert np.array_equal(np.asarray(out[name]), np.asarray(src[name])), name
    assert [type(v) for v in out.header.vlrs if not isinstance(v, laspy.vlrs.known.ExtraBytesVlr)] == \
        [type(v) for v in src.header.vlrs if not isinstance(v, laspy.vlrs.known.ExtraBytesVlr)]
    src_wkt = [v.string for v in src.header.vlrs if isinstance(v, laspy.vlrs.known.WktCoordinateSystemVlr)]
    out_wkt = [v.string for v in out.header.vlrs if isinstance(v, laspy.vlrs.known.WktCoordinateSystemVlr)]
    assert src_wkt and out_wkt == src_wkt
    assert np.array_equal(out.header.scales, src.header.scales)
    assert np.array_equal(out.header.offsets, src.header.offsets)
    extra = {d.name: d for d in out.point_format.extra_dimensions}
    expected = {"Cl", "Cs", "Cp", "Egeom", "GeomClass"} | ({"OptimalScale"} if strategy == "optimal" else set())
    assert set(extra) & OURS == expected
    for name in expected:
        desc = extra[name].description
        assert 0 < len(desc.encode()) <= 32
    assert extra["GeomClass"].dtype == np.uint16 and extra["Cl"].dtype == np.float32
    return out


@pytest.mark.parametrize("path", IGN_FILES or [IGN / "missing.laz"], ids=lambda p: p.name)
def test_ign_roundtrip_keeps_originals_and_does_not_duplicate(path, tmp_path):
    need_data(path)
    first, second = tmp_path / "first.laz", tmp_path / "second.laz"
    pipe = ls.Pipeline()
    result = pipe.run(path)
    result.write(first)
    out = _check_roundtrip(path, first, "multiscale")
    ok = result.saliency.defined
    np.testing.assert_array_equal(np.asarray(out["Cl"])[ok], result.saliency.cl[ok].astype(np.float32))
    assert np.isnan(np.asarray(out["Cl"])[~ok]).all()
    assert np.array_equal(np.asarray(out["GeomClass"]), result.saliency.geom_class)
    # a second run on the output replaces the dimensions instead of adding duplicates
    pipe.run(first).write(second)
    out2 = _check_roundtrip(path, second, "multiscale")
    names = list(out2.point_format.extra_dimension_names)
    assert len(names) == len(set(names)) == 5
    np.testing.assert_array_equal(np.asarray(out2["Cp"]), np.asarray(out["Cp"]))


def test_optimal_scale_dimension_holds_k(tmp_path):
    path = need_data(IGN / "test_data_77060_627760_LA93_IGN69.laz")
    out_path = tmp_path / "opt.las"
    result = ls.Pipeline(strategy="optimal").run(path)
    result.write(out_path)
    out = _check_roundtrip(path, out_path, "optimal")
    k = np.asarray(out["OptimalScale"])
    assert set(np.unique(k)) <= set(range(10, 101, 10))
    assert np.array_equal(k, (result.saliency.optimal_scale + 1) * 10)
    # switching strategy on a re-run drops the OptimalScale dimension
    again = tmp_path / "again.laz"
    ls.Pipeline().run(out_path).write(again)
    assert "OptimalScale" not in set(laspy.read(again).point_format.extra_dimension_names)


def test_write_refuses_existing_output(tmp_path):
    path = need_data(IGN / "test_data_77060_627760_LA93_IGN69.laz")
    out_path = tmp_path / "o.laz"
    out_path.write_bytes(b"keep me")
    result = ls.Pipeline(scales=ls.knn(10)).run(path)
    with pytest.raises(ls.LidarSigError, match="overwrite=True"):
        result.write(out_path)
    assert out_path.read_bytes() == b"keep me"
    result.write(out_path, overwrite=True)
    assert len(laspy.read(out_path).points) == len(result.cloud)


@pytest.mark.parametrize("path", LAS12, ids=lambda p: p.name)
def test_las12_input_is_written_as_las14_with_every_value_kept(path, tmp_path):
    src = laspy.read(need_data(path))
    assert str(src.header.version) == "1.2"
    cloud = ls.read(path)
    sal = _saliency(len(cloud))
    out_path = tmp_path / "out.laz"
    with pytest.warns(LidarSigWarning, match="LAS 1.2 input written as LAS 1.4"):
        write_las(out_path, cloud, saliency_fields(sal))
    out = laspy.read(out_path)
    assert str(out.header.version) == "1.4"
    assert out.header.point_format.id == {0: 6, 1: 6}[src.header.point_format.id]
    for name in src.point_format.dimension_names:
        if name == "scan_angle_rank":  # LAS 1.4: scan_angle in 0.006 degree steps
            assert np.array_equal(np.round(np.asarray(out.scan_angle) * 0.006), np.asarray(src.scan_angle_rank))
        else:
            assert np.array_equal(np.asarray(out[name]), np.asarray(src[name])), name
    assert np.array_equal(out.header.scales, src.header.scales)
    assert np.array_equal(out.header.offsets, src.header.offsets)
    for field in ("system_identifier", "file_source_id", "uuid"):
        assert getattr(out.header, field) == getattr(src.header, field), field
    assert out.header.global_encoding.gps_time_type == src.header.global_encoding.gps_time_type
    # saliency in the extra-bytes VLR, which LAS 1.4 defines
    records = out.header.vlrs.get("ExtraBytesVlr")[0].extra_bytes_structs
    assert [r.format_name() for r in records] == ["Cl", "Cs", "Cp", "Egeom", "GeomClass"]
    np.testing.assert_array_equal(np.asarray(out["Cp"]), sal.cp.astype(np.float32))
    # CRS: GeoTIFF keys kept, the same CRS as WKT behind the WKT bit LAS 1.4 requires for PF 6-10
    assert out.header.global_encoding.wkt
    epsg = README_EPSG["ahn3" if "ahn3" in path.name else "isprs"]
    src_keys = src.header.vlrs.get("GeoKeyDirectoryVlr")
    out_keys = out.header.vlrs.get("GeoKeyDirectoryVlr")
    assert [(k.id, k.value_offset) for v in out_keys for k in v.geo_keys] == \
        [(k.id, k.value_offset) for v in src_keys for k in v.geo_keys]
    wkt = out.header.vlrs.get("WktCoordinateSystemVlr")
    if epsg is None:
        assert not wkt and out.header.parse_crs() is None
    else:
        assert len(wkt) == 1 and wkt[0].parse_crs().to_epsg() == epsg


@pytest.mark.parametrize("fmt", [0, 1, 2, 3, 4, 5])
def test_legacy_point_formats_map_to_las14_with_values_kept(fmt, tmp_path):
    """Every dimension of LAS 1.3 formats 0-5 filled with random values over its whole range
    (classification 0-31 and the flags included) survives the upgrade."""
    xyz, _ = airborne_like(n=2000)
    rng = np.random.default_rng(fmt)
    las = laspy.create(point_format=fmt, file_version="1.3")
    las.header.scales, las.header.offsets = [0.001] * 3, [0.0] * 3
    las.x, las.y, las.z = xyz.T
    for dim in las.point_format.dimensions:
        if dim.name in ("X", "Y", "Z"):
            continue
        dtype = dim.dtype if dim.dtype is not None else np.dtype(np.int64)  # None: a bit field
        if dtype.kind == "f":
            las[dim.name] = rng.uniform(-1e6, 1e6, len(xyz))
        else:
            las[dim.name] = rng.integers(dim.min, dim.max, len(xyz), endpoint=True, dtype=dtype)
    src_path, out_path = tmp_path / "in.las", tmp_path / "out.las"
    las.write(src_path)
    src = laspy.read(src_path)
    assert np.unique(np.asarray(src.classification)).size == 32 and np.asarray(src.withheld).any()
    with pytest.warns(LidarSigWarning):
        write_las(out_path, ls.read(src_path), saliency_fields(_saliency(len(xyz))))
    out = laspy.read(out_path)
    assert out.header.point_format.id == {0: 6, 1: 6, 2: 7, 3: 7, 4: 9, 5: 10}[fmt]
    for name in src.point_format.dimension_names:
        if name == "scan_angle_rank":
            assert np.array_equal(np.round(np.asarray(out.scan_angle) * 0.006), np.asarray(src.scan_angle_rank))
        else:
            assert np.array_equal(np.asarray(out[name]), np.asarray(src[name])), name


def test_copc_input_is_written_as_plain_laz_with_one_note(tmp_path):
    path = need_data(COPC)
    out_path = tmp_path / "out.laz"
    proc = run("saliency", path, "-o", out_path, "--k", "10", "-q")
    assert proc.returncode == 0, proc.stderr
    notes = proc.stderr.strip().splitlines()
    assert len(notes) == 1 and "COPC" in notes[0] and "Traceback" not in proc.stderr
    src, out = laspy.read(path), laspy.read(out_path)
    assert str(out.header.version) == "1.4" and out.header.point_format.id == src.header.point_format.id
    assert all(v.user_id != "copc" for v in list(out.header.vlrs) + list(out.header.evlrs or []))
    for name in src.point_format.dimension_names:
        assert np.array_equal(np.asarray(out[name]), np.asarray(src[name])), name
    assert set(out.point_format.extra_dimension_names) == {"Cl", "Cs", "Cp", "Egeom", "GeomClass"}
    assert out.header.parse_crs().to_epsg() == 2154  # the data README's EPSG for this tile


@pytest.mark.parametrize("ext", [".las", ".laz"])
def test_extra_bytes_records_hold_the_data_range_and_no_data(ext, tmp_path):
    path = need_data(IGN / "test_data_77060_627760_LA93_IGN69.laz")
    cloud = ls.read(path)
    sal = _saliency(len(cloud), undefined=0.2)
    sal.values[0] = np.nan  # the first point undefined too
    sal = ls.Saliency.from_values(sal.values)
    write_las(tmp_path / f"o{ext}", cloud, saliency_fields(sal))
    out = laspy.read(tmp_path / f"o{ext}")
    records = {r.format_name(): r for r in out.header.vlrs.get("ExtraBytesVlr")[0].extra_bytes_structs}
    for name in ("Cl", "Cs", "Cp", "Egeom"):
        values = np.asarray(out[name])
        assert np.isnan(values).sum() == (~sal.defined).sum()
        assert records[name].min[0] == np.nanmin(values) and records[name].max[0] == np.nanmax(values)
        assert np.isnan(records[name].no_data[0])
    geom = np.asarray(out["GeomClass"])
    assert records["GeomClass"].no_data[0] == 0
    assert (records["GeomClass"].min[0], records["GeomClass"].max[0]) == (geom[geom > 0].min(), geom.max())


def test_a_users_extra_bytes_record_flagging_one_bound_gets_its_true_range(tmp_path):
    # a record with its max alone flagged has no min to write (it used to raise a TypeError)
    xyz, labels = airborne_like(600)
    las = laspy.LasData(laspy.LasHeader(point_format=6, version="1.4"))
    las.header.offsets, las.header.scales = xyz.min(axis=0), [0.001] * 3
    las.x, las.y, las.z = xyz.T
    las.add_extra_dim(laspy.ExtraBytesParams(name="height", type=np.float32, description="my height"))
    height = np.linspace(9.0, 5.0, len(xyz)).astype(np.float32)
    las["height"] = height
    las.header.vlrs.get("ExtraBytesVlr")[0].extra_bytes_structs[0].options = 4  # max only
    las.write(tmp_path / "user.las")
    header = laspy.read(tmp_path / "user.las").header
    from lidar_sig.io.las import set_extra_bytes_ranges

    set_extra_bytes_ranges(header, laspy.read(tmp_path / "user.las").points)
    record = header.vlrs.get("ExtraBytesVlr")[0].extra_bytes_structs[0]
    assert record.min is None and record.max[0] == 9.0
    ls.Pipeline(scales=ls.knn(10)).run(tmp_path / "user.las").write(tmp_path / "out.las")
    out = laspy.read(tmp_path / "out.las")
    records = {r.format_name(): r for r in out.header.vlrs.get("ExtraBytesVlr")[0].extra_bytes_structs}
    np.testing.assert_array_equal(np.asarray(out["height"]), height)
    assert (records["height"].min[0], records["height"].max[0]) == (5.0, 9.0)
    assert records["Cl"].min[0] == np.nanmin(np.asarray(out["Cl"]))


def test_header_names_lidar_sig_and_today(tmp_path):
    path = need_data(IGN / "test_data_77060_627760_LA93_IGN69.laz")
    cloud = ls.read(path)
    assert cloud.source.header.generating_software.startswith("PDAL")
    write_las(tmp_path / "o.laz", cloud, saliency_fields(_saliency(len(cloud))))
    out = laspy.read(tmp_path / "o.laz")
    assert out.header.generating_software == f"lidar_sig {ls.__version__}"
    assert out.header.creation_date == datetime.date.today()
    assert str(out.header.version) == "1.4" and out.header.point_format.id == 8
    assert out.header.global_encoding.value == cloud.source.header.global_encoding.value


def test_a_users_own_cl_dimension_is_kept_and_ours_is_prefixed(tmp_path):
    path = need_data(IGN / "test_data_77060_627760_LA93_IGN69.laz")
    las = laspy.read(path)
    chlorophyll = np.linspace(0.0, 50.0, len(las.points))
    las.add_extra_dim(laspy.ExtraBytesParams(name="Cl", type=np.float64, description="chlorophyll"))
    las["Cl"] = chlorophyll
    user = tmp_path / "user.laz"
    las.write(user)
    first, second = tmp_path / "first.laz", tmp_path / "second.laz"
    result = ls.Pipeline(scales=ls.knn(10)).run(user)
    with pytest.warns(LidarSigWarning, match="lidar_sig_Cl"):
        result.write(first)
    out = laspy.read(first)
    np.testing.assert_array_equal(np.asarray(out["Cl"]), chlorophyll)
    extra = {d.name: d for d in out.point_format.extra_dimensions}
    assert extra["Cl"].description == "chlorophyll" and extra["Cl"].dtype == np.float64
    assert {"lidar_sig_Cl", "lidar_sig_Cs", "lidar_sig_Cp", "lidar_sig_Egeom", "lidar_sig_GeomClass"} <= set(extra)
    ok = result.saliency.defined
    np.testing.assert_array_equal(np.asarray(out["lidar_sig_Cl"])[ok], result.saliency.cl[ok].astype(np.float32))
    # a re-run replaces the prefixed dimensions and still keeps the user's
    with pytest.warns(LidarSigWarning, match="lidar_sig_Cl"):
        ls.Pipeline(scales=ls.knn(10)).run(first).write(second)
    names = list(laspy.read(second).point_format.extra_dimension_names)
    assert sorted(names) == sorted(["Cl", "lidar_sig_Cl", "lidar_sig_Cs", "lidar_sig_Cp", "lidar_sig_Egeom",
                                    "lidar_sig_GeomClass"])
    np.testing.assert_array_equal(np.asarray(laspy.read(second)["Cl"]), chlorophyll)


def test_cli_refuses_when_even_the_prefixed_names_are_taken(tmp_path):
    las = laspy.read(need_data(IGN / "test_data_77060_627760_LA93_IGN69.laz"))
    las.add_extra_dims([laspy.ExtraBytesParams(name="Cl", type=np.float64, description="chlorophyll"),
                        laspy.ExtraBytesParams(name="lidar_sig_Cl", type=np.float64, description="another")])
    user = tmp_path / "user.laz"
    las.write(user)
    out = tmp_path / "out" / "o.laz"
    out.parent.mkdir()
    proc = run("saliency", user, "-o", out, "--k", "10", "-q")
    assert proc.returncode == 2
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and "user.laz" in lines[0] and "lidar_sig_Cl" in lines[0] and "rename" in lines[0]
    assert list(out.parent.iterdir()) == []


@pytest.mark.parametrize("version,point_format", [("1.4", 6), ("1.2", 1)])
def test_withheld_and_noise_points_are_left_out_by_default_and_kept_on_request(tmp_path, version, point_format):
    path = tmp_path / "noisy.las"
    scene = noisy_las(path, version=version, point_format=point_format)
    n_left_out = sum(NOISY.values())
    cloud = ls.read(path)
    result = ls.Pipeline(progress=False).run(cloud)
    # the scene's saliency and signature are those of the scene alone: the others are absent
    clean = ls.Pipeline(progress=False).run(ls.PointCloud(cloud.xyz[scene], cloud.labels[scene]))
    np.testing.assert_allclose(result.saliency.values[scene], clean.saliency.values, rtol=0, atol=1e-12)
    assert np.isnan(result.saliency.values[~scene]).all() and (result.saliency.geom_class[~scene] == 0).all()
    assert np.array_equal(result.signature.counts, clean.signature.counts)
    totals = result.signature.class_totals
    assert np.array_equal(totals, clean.signature.class_totals) and totals[7] == totals[18] == 0
    assert result.metadata["n_excluded"] == n_left_out and result.metadata["n_points"] == len(cloud)
    assert result.signature.n_undefined == clean.signature.n_undefined  # left-out points are not "undefined"
    # every point is still in the output, the left-out ones undefined
    out = tmp_path / "out.las"
    with pytest.warns(LidarSigWarning, match="as LAS 1.4") if version != "1.4" else contextlib.nullcontext():
        result.write(out)
    las = laspy.read(out)
    assert len(las.points) == len(cloud)
    assert np.array_equal(np.asarray(las.classification), cloud.labels)
    assert np.isnan(np.asarray(las["Cl"])[~scene]).all() and (np.asarray(las["GeomClass"])[~scene] == 0).all()
    assert np.isfinite(np.asarray(las["Cl"])[scene]).mean() > 0.95
    # keep_noise uses every point: noise classes in the class totals, noise points defined
    kept = ls.Pipeline(progress=False, keep_noise=True).run(cloud)
    assert kept.metadata["n_excluded"] == 0 and kept.metadata["keep_noise"] is True
    totals = kept.signature.class_totals
    assert totals[7] == NOISY[7] and totals[18] == NOISY[18] and totals.sum() == len(cloud)
    assert totals[2] == clean.signature.class_totals[2] + NOISY["withheld"]  # withheld ground points
    assert kept.saliency.defined[~scene].mean() > 0.5


def test_cli_summary_says_how_many_points_were_left_out(tmp_path):
    path = tmp_path / "noisy.laz"
    noisy_las(path)
    default = run("saliency", path, "-o", tmp_path / "a.laz")
    assert default.returncode == 0, default.stderr
    assert f"{sum(NOISY.values())} withheld or noise points left out" in default.stdout
    kept = run("saliency", path, "-o", tmp_path / "b.laz", "--keep-noise")
    assert kept.returncode == 0, kept.stderr
    assert "left out" not in kept.stdout
    assert np.isfinite(np.asarray(laspy.read(tmp_path / "b.laz")["Cl"])[-NOISY[18]:]).any()
    info = run("info", path)
    assert f"withheld: {NOISY['withheld']} points" in info.stdout, info.stderr


def test_info_says_one_withheld_point_in_the_singular(tmp_path, capsys):
    from lidar_sig.cli import main

    xyz, labels = airborne_like(200, seed=5)
    las = laspy.create(point_format=6, file_version="1.4")
    las.x, las.y, las.z = xyz.T
    las.classification = labels
    withheld = np.zeros(len(xyz), bool)
    withheld[3] = True
    las.withheld = withheld
    las.write(tmp_path / "one.las")
    assert main(["info", str(tmp_path / "one.las")]) == 0
    assert "withheld: 1 point (left out" in capsys.readouterr().out


def test_noise_codes_follow_the_class_table():
    # a labelled cloud of any format: 7 and 18 are noise in the ASPRS tables, 7 a shrub in Vaihingen's
    xyz, labels = airborne_like(2000, seed=4)
    labels = labels.copy()
    labels[:100] = 7
    cloud = ls.PointCloud(xyz, labels)
    for classes, left_out in (("asprs", 100), ("paper", 100), ("isprs-vaihingen", 0)):
        result = ls.Pipeline(scales=ls.knn(10, 20), classes=classes, progress=False).run(cloud)
        assert result.metadata["n_excluded"] == left_out, classes
        assert np.isnan(result.saliency.values[:100]).all() == bool(left_out), classes
    assert ls.Pipeline(scales=ls.knn(10, 20), progress=False).run(ls.PointCloud(xyz)).metadata["n_excluded"] == 0
    with pytest.raises(ls.LidarSigError, match="every point.*keep_noise"):
        ls.Pipeline(progress=False).run(ls.PointCloud(xyz, np.full(len(xyz), 18)))


@pytest.mark.parametrize("suffix", [".laz", ".ply"])
def test_a_run_replaces_its_own_outputs_and_keeps_the_other_runs(tmp_path, suffix):
    # the change map's per-point change survives a saliency re-run, and the saliency a change
    # map's points; each run replaces only what it writes itself
    if suffix == ".ply":
        pytest.importorskip("open3d", reason="PLY needs open3d: pip install -e '.[formats]'")
    from conftest import SAMPLES

    later = tmp_path / "later.laz"  # an epoch is LAS/LAZ (it has a CRS)
    ls.Pipeline(progress=False).run(SAMPLES / "epoch2.laz").write(later)
    points = tmp_path / ("points" + suffix)
    done = run("changes", SAMPLES / "epoch1.laz", later, "--points", points, "-q")
    assert done.returncode == 0, done.stderr
    again = tmp_path / ("again" + suffix)
    done = run("saliency", points, "-o", again, "--strategy", "optimal", "-q")
    assert done.returncode == 0, done.stderr
    names = list(ls.read(again).attributes) if suffix == ".ply" else \
        list(laspy.read(again).point_format.extra_dimension_names)
    plain = [n.removeprefix("scalar_") for n in names]
    for name in ("Cl", "Cs", "Cp", "Egeom", "GeomClass", "OptimalScale", "ChangeScore", "ChangeLoD",
                 "ChangeSignificant"):
        assert plain.count(name) == 1, (name, names)
    assert not any(n.startswith("lidar_sig_") for n in plain), names


def test_a_las_1_4_file_with_evlrs_streamed_from_tiles_keeps_them(tmp_path):
    # the streamed writer gave laspy a plain list of EVLRs: "'list' object has no attribute 'write_to'"
    las = laspy.read(SAMPLES / "epoch1.laz")
    las.evlrs = laspy.vlrs.vlrlist.VLRList([laspy.VLR("lidar_sig_test", 7, "a note", b"kept")])
    las.write(tmp_path / "evlr.laz")
    ls.jobs.saliency(tmp_path / "evlr.laz", tmp_path / "out.laz", execution=ls.Execution(tile_size=30, workers=1),
                     pipeline=ls.Pipeline(progress=False))
    out = laspy.read(tmp_path / "out.laz")
    assert [(v.user_id, v.record_id, v.record_data) for v in out.evlrs] == [("lidar_sig_test", 7, b"kept")]
    assert len(out) == len(las)
