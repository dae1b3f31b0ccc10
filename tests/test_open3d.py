"""Open3D point clouds in and out (issue 10): Pipeline.run takes legacy and tensor clouds like
the same points given directly; Result.to_open3d carries every per-point output."""
import numpy as np
import pytest

import lidar_sig as ls
from conftest import airborne_like

o3d = pytest.importorskip("open3d", reason="Open3D clouds need open3d: pip install -e '.[formats]'")

SCALES = ls.radii(0.6, 0.8, units="metric")  # small enough to leave some points undefined


@pytest.fixture(scope="module")
def scene():
    xyz, labels = airborne_like(n=3000, seed=3)
    rng = np.random.default_rng(3)
    return xyz, labels, rng.random((len(xyz), 3)), rng.integers(0, 900, len(xyz)).astype(np.float32)


@pytest.fixture(scope="module")
def direct(scene):
    xyz, labels, _, _ = scene
    return ls.Pipeline(scales=SCALES).run(ls.PointCloud(xyz, labels))


def _same_run(a, b):
    np.testing.assert_array_equal(a.saliency.values, b.saliency.values)
    np.testing.assert_array_equal(a.signature.counts, b.signature.counts)


def test_legacy_cloud_runs_like_its_points(scene, direct):
    xyz, _, colors, _ = scene
    pcd = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(xyz))
    pcd.colors = o3d.utility.Vector3dVector(colors)
    pcd.estimate_normals()
    result = ls.Pipeline(scales=SCALES).run(pcd)
    assert result.cloud.labels is None
    unlabeled = ls.Pipeline(scales=SCALES).run(ls.PointCloud(xyz))
    _same_run(result, unlabeled)
    np.testing.assert_array_equal(result.cloud.attributes["colors"], colors)
    assert result.cloud.attributes["normals"].shape == xyz.shape


def test_tensor_cloud_runs_like_its_points_with_labels_and_attributes(scene, direct):
    xyz, labels, colors, intensity = scene
    pc = o3d.t.geometry.PointCloud()
    pc.point.positions = o3d.core.Tensor(xyz)
    pc.point.colors = o3d.core.Tensor(colors.astype(np.float32))
    pc.point.intensity = o3d.core.Tensor(intensity.reshape(-1, 1))
    pc.point.label = o3d.core.Tensor(labels.astype(np.int32).reshape(-1, 1))
    result = ls.Pipeline(scales=SCALES).run(pc)
    _same_run(result, direct)
    np.testing.assert_array_equal(result.cloud.labels, labels)
    np.testing.assert_array_equal(result.cloud.attributes["intensity"], intensity)
    np.testing.assert_array_equal(result.cloud.attributes["colors"], colors.astype(np.float32))


def test_to_open3d_carries_every_per_point_output(direct):
    sal = direct.saliency
    assert 0 < (~sal.defined).sum() < len(sal.defined)
    pc = direct.to_open3d()
    assert isinstance(pc, o3d.t.geometry.PointCloud)
    assert set(pc.point) == {"positions", "colors", "Cl", "Cs", "Cp", "Egeom", "GeomClass", "label"}
    np.testing.assert_array_equal(pc.point.positions.numpy(), direct.cloud.xyz)
    for name, values in [("Cl", sal.cl), ("Cs", sal.cs), ("Cp", sal.cp), ("Egeom", sal.egeom)]:
        np.testing.assert_array_equal(pc.point[name].numpy()[:, 0], values.astype(np.float32))
    np.testing.assert_array_equal(pc.point.GeomClass.numpy()[:, 0], sal.geom_class)
    np.testing.assert_array_equal(pc.point.label.numpy()[:, 0], direct.cloud.labels)
    rgb = pc.point.colors.numpy()
    assert rgb.dtype == np.float32
    np.testing.assert_allclose(rgb[sal.defined], sal.values[sal.defined], rtol=1e-6)
    assert np.all(rgb[~sal.defined] == 0.5)  # undefined: neutral grey
    assert "colors" not in direct.to_open3d(colors=None).point


def test_to_open3d_optimal_scale_and_back(scene):
    xyz, labels, _, _ = scene
    result = ls.Pipeline(strategy="optimal", scales=ls.knn(10, 20)).run(ls.PointCloud(xyz, labels))
    pc = result.to_open3d()
    assert set(np.unique(pc.point.OptimalScale.numpy())) <= {10, 20}
    back = ls.Pipeline(strategy="optimal", scales=ls.knn(10, 20)).run(pc)
    _same_run(back, result)
    np.testing.assert_array_equal(back.cloud.attributes["Cl"], result.saliency.cl.astype(np.float32))


def test_empty_open3d_cloud_is_a_user_error():
    with pytest.raises(ls.LidarSigError, match="no points"):
        ls.Pipeline().run(o3d.geometry.PointCloud())
