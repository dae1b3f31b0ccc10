"""LAS/LAZ output (SPEC 8): originals kept bit for bit, saliency dimensions added once."""
import laspy
import numpy as np
import pytest

import lidar_sig as ls
from conftest import IGN, IGN_FILES, need_data
from lidar_sig.io.las import SALIENCY_DIMS

OURS = set(SALIENCY_DIMS)


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
    with pytest.raises(ls.LidarSigError, match="--overwrite"):
        result.write(out_path)
    assert out_path.read_bytes() == b"keep me"
    result.write(out_path, overwrite=True)
    assert len(laspy.read(out_path).points) == len(result.cloud)
