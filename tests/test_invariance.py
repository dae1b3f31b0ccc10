"""Invariances of C3DCM saliency and signatures (SPEC 7)."""
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import lidar_sig as ls
from conftest import airborne_like

# Radii chosen off the 2^-10 coordinate grid so that no neighbour sits exactly on a sphere.
METRIC = ls.radii(0.8137, 1.1291, 1.5467, units="metric")
CASES = [("multiscale", METRIC), ("optimal", None)]


def _run(xyz, labels, strategy, scales):
    return ls.Pipeline(strategy=strategy, scales=scales).run(ls.PointCloud(xyz, labels))


def _assert_same(r1, r2, order=None):
    v2 = r2.saliency.values if order is None else r2.saliency.values[np.argsort(order)]
    np.testing.assert_allclose(r1.saliency.values, v2, atol=1e-6)
    assert np.array_equal(r1.signature.counts, r2.signature.counts)
    assert np.array_equal(r1.signature.egeom_counts, r2.signature.egeom_counts)


@pytest.fixture(scope="module")
def scene():
    return airborne_like(4000, seed=5)


@pytest.mark.parametrize("strategy,scales", CASES)
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_any_rotation(scene, strategy, scales, seed):
    # Metric radii or k: normalized radii follow the axis-aligned bounding box, which turns.
    xyz, labels = scene
    rot = Rotation.random(random_state=seed).as_matrix()
    _assert_same(_run(xyz, labels, strategy, scales), _run(xyz @ rot.T, labels, strategy, scales))


@pytest.mark.parametrize("strategy,scales", CASES + [("multiscale", None)])
def test_translation_by_utm_offsets(scene, strategy, scales):
    xyz, labels = scene
    moved = xyz + [652731.0, 6862119.0, 120.0]
    _assert_same(_run(xyz, labels, strategy, scales), _run(moved, labels, strategy, scales))


@pytest.mark.parametrize("factor", [0.3048, 100.0, 1 / 3])
def test_uniform_scaling_with_normalized_radii(factor):
    xyz, labels = airborne_like(4000, seed=6, quantum=None)
    scales = ls.radii(0.03, 0.04, 0.05, units="normalized")
    r1 = _run(xyz, labels, "multiscale", scales)
    r2 = _run(xyz * factor, labels, "multiscale", scales)
    _assert_same(r1, r2)
    # k-nearest scales are unit-free too
    _assert_same(_run(xyz, labels, "optimal", None), _run(xyz * factor, labels, "optimal", None))


@pytest.mark.parametrize("strategy,scales", CASES + [("multiscale", None)])
def test_point_order(scene, strategy, scales):
    xyz, labels = airborne_like(4000, seed=8, quantum=None)
    order = np.random.default_rng(3).permutation(len(xyz))
    _assert_same(_run(xyz, labels, strategy, scales), _run(xyz[order], labels[order], strategy, scales),
                 order)
