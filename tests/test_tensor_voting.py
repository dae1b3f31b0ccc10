"""T3DVT and T3DVT-GET on synthetic shapes with known answers (SPEC 3), and invariances (SPEC 7)."""
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import lidar_sig as ls
from conftest import airborne_like
from lidar_sig.numerics.neighbors import NeighborIndex
from lidar_sig.plugins.descriptors.t3dvt import T3DVT
from lidar_sig.plugins.descriptors.t3dvt_get import T3DVTGET, cl_get_of_cloud


def _grid_plane(step=0.1, half=20):
    g = np.arange(-half, half + 1) * step
    x, y = np.meshgrid(g, g)
    return np.column_stack([x.ravel(), y.ravel(), np.zeros(x.size)])


def _saliency_at(points, row, radius, descriptor, max_neighbors=512):
    index = NeighborIndex(points, "radius", np.array([radius]), max_neighbors=max_neighbors)
    return descriptor.saliency(index.query(index.rows_of([row])))[0, 0]


@pytest.mark.parametrize("radius", [0.25, 0.55, 1.2])
def test_diffused_voting_on_regular_plane(radius):
    pts = _grid_plane()
    centre = int(np.argmin(np.linalg.norm(pts, axis=1)))
    np.testing.assert_allclose(_saliency_at(pts, centre, radius, T3DVT()), [0.0, 0.935, 0.065], atol=0.005)


def test_diffused_voting_on_regular_line():
    pts = np.column_stack([np.arange(-50, 51) * 0.1, np.zeros(101), np.zeros(101)])
    cl, cs, cp = _saliency_at(pts, 50, 0.5, T3DVT())
    assert cl > 0.99


def test_random_plane_mean_cl_falls_with_neighbour_count():
    rng = np.random.default_rng(0)
    pts = np.column_stack([rng.uniform(0, 100, (200000, 2)), np.zeros(200000)])
    density = 200000 / 100.0 ** 2
    centre = np.flatnonzero(np.all(np.abs(pts[:, :2] - 50) < 30, axis=1))[:2000]
    means = []
    for n_nb, expected in ((23, (0.51, 0.44, 0.05)), (78, (0.30, 0.64, 0.06)), (785, (0.10, 0.84, 0.06))):
        radius = np.sqrt(n_nb / (np.pi * density))
        index = NeighborIndex(pts, "radius", np.array([radius]), max_neighbors=2000)
        sal = T3DVT().saliency(index.query(np.sort(index.rows_of(centre))))[:, 0]
        mean = np.nanmean(sal, axis=0)
        np.testing.assert_allclose(mean, expected, atol=0.03)
        means.append(mean[0])
    assert means[0] > means[1] > means[2]


def test_raw_voting_reads_a_plane_as_point_type():
    pts = _grid_plane()
    centre = int(np.argmin(np.linalg.norm(pts, axis=1)))
    cl, cs, cp = _saliency_at(pts, centre, 0.55, T3DVT(diffusion=False))
    assert cp > cs and cp > 0.7


def _height_field(z_of):
    g = np.arange(-30, 31) * 0.1
    x, y = np.meshgrid(g, g)
    x, y = x.ravel(), y.ravel()
    return np.column_stack([x, y, z_of(x, y)])


def test_get_on_gable_ridge_is_line_type():
    pts = _height_field(lambda x, y: 6 - 0.5 * np.abs(y))
    cl = cl_get_of_cloud(pts, "radius", np.array([0.25, 0.35, 0.45]))
    ridge = (pts[:, 1] == 0) & (np.abs(pts[:, 0]) < 2)
    assert np.all(cl[ridge] > 0.9)  # at every scale


def test_get_on_pyramid_apex_is_corner():
    pts = _height_field(lambda x, y: 6 - 0.5 * np.maximum(np.abs(x), np.abs(y)))
    cl = cl_get_of_cloud(pts, "radius", np.array([0.25, 0.35, 0.45]))
    apex = (pts[:, 0] == 0) & (pts[:, 1] == 0)
    assert np.all(1 - cl[apex] > 0.8)  # at every scale


@pytest.mark.parametrize("slope,threshold", [(0.5, 0.0), (1.5, None)])
def test_get_turns_apex_into_corner_in_pipeline(slope, threshold):
    # a gentle pyramid roof needs threshold 0; a steep one is a corner at the default too
    pts = _height_field(lambda x, y: 6 - slope * np.maximum(np.abs(x), np.abs(y)))
    scales = ls.radii(0.25, 0.35, 0.45, units="metric")
    descriptor = T3DVTGET() if threshold is None else T3DVTGET(get_threshold=threshold)
    res = ls.Pipeline(descriptor=descriptor, scales=scales).run(ls.PointCloud(pts))
    apex = int(np.flatnonzero((pts[:, 0] == 0) & (pts[:, 1] == 0))[0])
    cl, cs, cp = res.saliency.values[apex]
    assert cs == 0 and cp > 0.8 and res.saliency.geom_class[apex] == 3
    plain = ls.Pipeline(descriptor="t3dvt", scales=scales).run(ls.PointCloud(pts))
    assert not np.allclose(plain.saliency.values[apex], res.saliency.values[apex])  # GET's doing


# ---- invariances --------------------------------------------------------------------------
METRIC = ls.radii(0.8137, 1.1291, 1.5467, units="metric")


def _run(xyz, descriptor, strategy="multiscale", scales=METRIC):
    return ls.Pipeline(descriptor=descriptor, strategy=strategy, scales=scales).run(ls.PointCloud(xyz))


def _same(r1, r2, order=None):
    v2 = r2.saliency.values if order is None else r2.saliency.values[np.argsort(order)]
    np.testing.assert_allclose(r1.saliency.values, v2, atol=1e-6)
    assert np.array_equal(r1.signature.counts, r2.signature.counts)


@pytest.fixture(scope="module")
def scene():
    return airborne_like(3000, seed=21, quantum=None)[0]


@pytest.mark.parametrize("strategy,scales", [("multiscale", METRIC), ("optimal", None)])
@pytest.mark.parametrize("seed", [0, 1])
def test_t3dvt_any_rotation(scene, strategy, scales, seed):
    rot = Rotation.random(random_state=seed).as_matrix()
    _same(_run(scene, "t3dvt", strategy, scales), _run(scene @ rot.T, "t3dvt", strategy, scales))


@pytest.mark.parametrize("angle", [17.0, 90.0, 233.0])
def test_t3dvt_get_rotation_about_z(scene, angle):
    rot = Rotation.from_euler("z", angle, degrees=True).as_matrix()
    _same(_run(scene, "t3dvt-get"), _run(scene @ rot.T, "t3dvt-get"))


@pytest.mark.parametrize("descriptor", ["t3dvt", "t3dvt-get"])
def test_translation_and_point_order(descriptor):
    xyz = airborne_like(3000, seed=22)[0]  # quantized: the UTM offset is exact
    base = _run(xyz, descriptor)
    _same(base, _run(xyz + [652731.0, 6862119.0, 120.0], descriptor))
    order = np.random.default_rng(4).permutation(len(xyz))
    _same(base, _run(xyz[order], descriptor), order)


def test_get_threshold_leaves_flat_ground_undefined():
    rng = np.random.default_rng(5)
    xy = rng.uniform(0, 30, (6000, 2))
    pts = np.column_stack([xy, 0.1 * xy[:, 0] + 0.05 * xy[:, 1]])  # evenly sloped: GET is round-off
    scales = np.array([0.8, 1.0, 1.2])
    loose = cl_get_of_cloud(pts, "radius", scales, threshold=0.0)
    strict = cl_get_of_cloud(pts, "radius", scales, threshold=1e-6)
    assert np.isfinite(loose).any(axis=1).mean() > 0.5  # round-off decides line or corner
    assert np.isnan(strict).all()              # the threshold leaves them undefined: no corners
    assert T3DVTGET(get_threshold=1e-6).params()["get_threshold"] == 1e-6


def test_get_leaves_a_point_without_voting_neighbours_undefined():
    # a point 20 m above a steep pyramid roof: no other point within the spheres (T3DVT
    # undefined), but its cylinders hold the roof below, whose GET reads a corner there
    pts = _height_field(lambda x, y: 6 - 1.5 * np.maximum(np.abs(x), np.abs(y)))
    pts = np.vstack([pts, [1.03, 0.52, 6 - 1.5 * 1.03 + 20.0]])
    scales = ls.radii(0.25, 0.35, 0.45, units="metric")
    res = ls.Pipeline(descriptor=T3DVTGET(), scales=scales, progress=False).run(ls.PointCloud(pts))
    assert np.isnan(res.saliency.values[-1]).all() and res.saliency.geom_class[-1] == 0
    assert res.metadata["n_undefined"] == 1 and res.signature.n_points == len(pts) - 1


def test_optimal_scale_get_takes_cl_get_at_the_chosen_scale(scene):
    # under Optimal-scale, GET is read at the scale chosen for the point (SPEC 3, step 3: "like
    # any saliency"); the per-scale cl_GET comes from one run per scale (a scale's cylinders
    # are the same alone as among others)
    cloud = ls.PointCloud(scene)
    pipe = ls.Pipeline(descriptor="t3dvt-get", strategy="optimal", progress=False)
    res = pipe.run(cloud)
    plain = ls.Pipeline(descriptor="t3dvt", strategy="optimal", progress=False).run(cloud)
    pick = plain.saliency.optimal_scale
    assert np.array_equal(res.saliency.optimal_scale, pick) and (pick >= 0).all()
    xyz = cloud.metric_xyz()
    threshold = pipe.descriptor.get_threshold
    cl = np.column_stack([cl_get_of_cloud(xyz, "knn", np.array([k]), threshold=threshold).ravel()
                          for k in pipe.scales.values])
    at = cl[np.arange(len(xyz)), pick]
    corner = at < 0.5  # cp_GET > cl_GET; False where GET is undefined at that scale
    expected = plain.saliency.values.copy()
    expected[corner] = np.column_stack([at[corner], np.zeros(int(corner.sum())), 1.0 - at[corner]])
    np.testing.assert_allclose(res.saliency.values, expected, rtol=0, atol=1e-9)
    # the scene has points where the mean over the scales and the chosen scale disagree
    defined = ~np.isnan(cl)
    mean = np.where(defined, cl, 0.0).sum(axis=1) / np.maximum(defined.sum(axis=1), 1)
    assert (((mean < 0.5) & defined.any(axis=1)) != corner).sum() > 10
