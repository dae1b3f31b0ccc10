"""Saliency map, geometric entropy and class (SPEC 1) and the C3DCM eigenvalues (SPEC 3)."""
import numpy as np
import pytest

import lidar_sig as ls
from lidar_sig.numerics.kernels import eigvalsh3
from lidar_sig.numerics.neighbors import NeighborIndex
from lidar_sig.plugins.descriptors.c3dcm import C3DCM
from lidar_sig.method.saliency_map import LN3, geometric_class, geometric_entropy, saliency_from_eigenvalues


def _centre_saliency(points, k=60):
    """Saliency of the point nearest the origin with its k nearest neighbours."""
    index = NeighborIndex(points, "knn", np.array([k]))
    row = index.rows_of([int(np.argmin(np.linalg.norm(points, axis=1)))])
    sal = C3DCM().saliency(index.query(row))[0, 0]
    return sal


@pytest.fixture
def rng():
    return np.random.default_rng(42)


def test_dense_plane_is_surface_type(rng):
    xy = rng.uniform(-1, 1, (5000, 2))
    pts = np.column_stack([xy, 1e-4 * rng.standard_normal(5000)])
    cl, cs, cp = _centre_saliency(pts)
    assert cs > 0.6 and cs > cl and cs > cp


def test_dense_line_is_line_type(rng):
    x = rng.uniform(-1, 1, 3000)
    pts = np.column_stack([x, 1e-4 * rng.standard_normal((3000, 2))])
    cl, cs, cp = _centre_saliency(pts)
    assert cl > 0.95


def test_dense_volume_is_point_type(rng):
    pts = rng.uniform(-1, 1, (20000, 3))
    cl, cs, cp = _centre_saliency(pts, k=400)
    assert cp > 0.7 and cp > cs and cp > cl


def test_covariance_eigenvalues_match_numpy_float64(rng):
    pts = rng.normal(size=(3000, 3)) * [3.0, 1.0, 0.2] + [650000.0, 6860000.0, 40.0]
    centred = pts - pts.mean(axis=0)
    ks = np.array([5, 17, 40])
    index = NeighborIndex(centred, "knn", ks)
    rows = np.sort(rng.choice(len(pts), 200, replace=False))
    batch = index.query(rows)
    ev = C3DCM().eigenvalues(batch)
    for b in range(len(rows)):
        for s, k in enumerate(ks):
            nb = pts[index.order[batch.idx[b, :k]]]  # raw UTM-sized coordinates, two-pass covariance
            ref = np.linalg.eigvalsh(np.cov(nb.T, bias=True))[::-1]
            np.testing.assert_allclose(ev[b, s], ref, rtol=1e-9, atol=1e-9 * ref[0])


def test_jacobi_eigenvalues_of_nearly_degenerate_matrix():
    # two equal in-plane eigenvalues: the case where the closed-form solution loses digits
    rot = np.linalg.qr(np.random.default_rng(1).normal(size=(3, 3)))[0]
    a = rot @ np.diag([1.0, 1.0 + 1e-12, 1e-9]) @ rot.T
    got = eigvalsh3(a[0, 0], a[1, 1], a[2, 2], a[0, 1], a[0, 2], a[1, 2])
    np.testing.assert_allclose(got, np.linalg.eigvalsh(a)[::-1], rtol=1e-9, atol=1e-15)


def test_saliency_sums_to_one_and_matches_formulas():
    ev = np.array([[3.0, 2.0, 1.0], [1.0, 0.0, 0.0], [1.0, 1.0, 1.0]])
    sal = saliency_from_eigenvalues(ev)
    np.testing.assert_allclose(sal.sum(axis=1), 1.0)
    np.testing.assert_allclose(sal[0], [1 / 6, 2 / 6, 3 / 6])
    np.testing.assert_allclose(sal[1], [1, 0, 0])
    np.testing.assert_allclose(sal[2], [0, 0, 1])


def test_zero_tensor_gives_undefined_saliency():
    sal = saliency_from_eigenvalues(np.zeros((1, 3)))
    assert np.isnan(sal).all()
    assert geometric_class(sal)[0] == 0
    assert np.isnan(geometric_entropy(sal)[0])


def test_entropy_bounds_and_zero_log_zero():
    sal = np.array([[1.0, 0.0, 0.0], [1 / 3, 1 / 3, 1 / 3], [0.5, 0.5, 0.0]])
    e = geometric_entropy(sal)
    np.testing.assert_allclose(e, [0.0, LN3, np.log(2)])


def test_geometric_class_ties_go_to_first():
    sal = np.array([[0.4, 0.4, 0.2], [0.2, 0.4, 0.4], [0.1, 0.2, 0.7]])
    assert geometric_class(sal).tolist() == [1, 2, 3]


def test_points_without_enough_neighbours_are_undefined_and_counted():
    rng = np.random.default_rng(3)
    dense = rng.uniform(0, 1, (2000, 3)) * [10, 10, 0.01]
    far = np.array([[100.0, 100.0, 0.0], [-100.0, 50.0, 0.0]])  # isolated points
    cloud = ls.PointCloud(np.vstack([dense, far]))
    result = ls.Pipeline(scales=ls.radii(0.5, units="metric")).run(cloud)
    assert result.metadata["n_undefined"] >= 2
    assert np.isnan(result.saliency.values[-2:]).all()
    assert result.signature.n_points == len(cloud) - result.metadata["n_undefined"]
    assert result.signature.n_undefined == result.metadata["n_undefined"]
