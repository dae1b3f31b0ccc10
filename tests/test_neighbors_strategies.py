"""Neighbourhood queries (SPEC 2) and the two scale strategies (SPEC 4)."""
import numpy as np
import pytest
from scipy.spatial import cKDTree

import lidar_sig as ls
from conftest import airborne_like
from lidar_sig.numerics.neighbors import TIE, NeighborIndex
from lidar_sig.plugins import get_strategy
from lidar_sig.method.saliency_map import geometric_entropy


@pytest.fixture
def pts():
    return np.random.default_rng(7).uniform(-5, 5, (3000, 3)) * [1, 1, 0.3]


def test_spherical_neighbourhoods_match_brute_force_grouped_by_scale(pts):
    radii = np.array([0.4, 0.7, 1.1])
    index = NeighborIndex(pts, "radius", radii, max_neighbors=512, min_neighbors=1)
    rows = np.arange(0, 3000, 37)
    batch = index.query(rows)
    for b, row in enumerate(rows):
        d = np.linalg.norm(index.xyz - index.xyz[row], axis=1)
        for s, r in enumerate(radii):
            assert batch.counts[b, s] == np.sum(d <= r)
            got = set(batch.idx[b, :batch.counts[b, s]].tolist())
            assert got == set(np.flatnonzero(d <= r).tolist())
        assert index.order[row] == batch.ids[b]


def test_knn_matches_kdtree_sorted_and_includes_query_point(pts):
    index = NeighborIndex(pts, "knn", np.array([5, 10, 40]))
    batch = index.query(np.arange(3000))
    ref, _ = cKDTree(index.xyz).query(index.xyz, k=40)
    np.testing.assert_allclose(batch.dist, ref, rtol=1e-12)
    assert (batch.dist[:, 0] == 0).all() and (batch.n == 40).all()
    np.testing.assert_allclose(batch.sigma[:, 1], batch.dist[:, 9])


def test_knn_on_real_like_cloud_with_outliers_matches_kdtree():
    xyz, _ = airborne_like(6000, seed=11, quantum=None)
    xyz = np.vstack([xyz, [[500.0, 500.0, 900.0], [-300.0, 20.0, 5.0]]])  # far outliers
    index = NeighborIndex(xyz - xyz.mean(0), "knn", np.arange(10, 101, 10))
    ref, _ = cKDTree(index.xyz).query(index.xyz, k=100)
    got = [index.query(rows).dist.copy() for rows in index.blocks()]
    width = max(g.shape[1] for g in got)
    got = np.vstack([np.pad(g, ((0, 0), (0, width - g.shape[1])), constant_values=np.inf) for g in got])
    np.testing.assert_allclose(got[:, :100], ref, rtol=1e-12)
    # past the 100th, only neighbours tied with it (to the documented tolerance) join
    extra = np.isfinite(got[:, 100:])
    assert (got[:, 100:][extra] <= np.repeat(ref[:, 99:], width - 100, axis=1)[extra] * np.sqrt(1 + TIE)).all()


def test_knn_lists_are_sorted_where_distances_crowd_into_few_values():
    # a lattice: every distance repeats many times, so the bucket sort of the candidates meets
    # crowded buckets and long runs of ties; the lists must still be exactly the k nearest, sorted
    g = np.arange(12, dtype=float)
    xyz = np.stack(np.meshgrid(g, g, g[:4], indexing="ij"), -1).reshape(-1, 3) * 0.5
    index = NeighborIndex(xyz, "knn", np.array([30, 60]))
    batch = index.query(np.arange(len(xyz)))
    ref, _ = cKDTree(index.xyz).query(index.xyz, k=60)
    np.testing.assert_allclose(batch.dist[:, :60], ref, rtol=1e-12)
    assert (np.diff(batch.d2[:, :60], axis=1) >= 0).all()


def _assert_as_a_tree_finds(index):
    """Every row of ``index`` (k = 10, 20) lists, counts and weighs what a k-d tree finds."""
    batch = index.query(np.arange(len(index.xyz)))
    ref, _ = cKDTree(index.xyz).query(index.xyz, k=20)
    np.testing.assert_allclose(batch.dist[:, :20], ref, rtol=1e-12)
    # the scales of every row, those the search settled (it counts them itself) and the others
    assert (batch.counts == [10, 20]).all() and (batch.n == 20).all()
    np.testing.assert_allclose(batch.sigma, ref[:, [9, 19]], rtol=1e-12)
    second, _ = cKDTree(index.xyz).query(index.xyz, k=3)
    np.testing.assert_allclose(index.second_distances(), second[:, 2], rtol=1e-12)


@pytest.mark.parametrize("scan_all", [0, 10**9])
def test_unsettled_queries_by_tree_or_by_scan_give_the_same_neighbours(monkeypatch, scan_all):
    # isolated points far from a dense patch: the voxel shells cannot settle them, and they are
    # completed either by a k-d tree or, when few, by a scan of every point
    import lidar_sig.numerics.neighbors as neighbors

    monkeypatch.setattr(neighbors, "_SCAN_ALL", scan_all)
    rng = np.random.default_rng(3)
    xyz = np.vstack([rng.uniform(0, 10, (2000, 3)) * [1, 1, 0.2], rng.uniform(200, 900, (30, 3))])
    index = NeighborIndex(xyz, "knn", np.array([10, 20]), weights="area")
    _assert_as_a_tree_finds(index)


@pytest.mark.parametrize("farther", [True, False])
def test_queries_a_few_shells_too_far_are_settled_by_more_shells(monkeypatch, farther):
    # a few points 7 to 9 m beside a dense patch (voxels of about 1 m): 6 shells cannot settle
    # their k nearest nor their second neighbour; a second search of 12 shells does, and gives
    # what a scan of every point gives (with _FARTHER_VOXELS = 0, the scan)
    import lidar_sig.numerics.neighbors as neighbors

    completed = []
    real = NeighborIndex._complete

    def complete(self, rows, *args, **kwargs):
        completed.append(len(rows))
        return real(self, rows, *args, **kwargs)

    monkeypatch.setattr(NeighborIndex, "_complete", complete)
    if not farther:
        monkeypatch.setattr(neighbors, "_FARTHER_VOXELS", 0)
    rng = np.random.default_rng(4)
    far = np.array([[37.0, 5.0, 0.0], [39.0, 15.0, 0.3], [37.0, 25.0, 0.1]])
    xyz = np.vstack([rng.uniform(0, 30, (20000, 3)) * [1, 1, 0.003], far])
    index = NeighborIndex(xyz, "knn", np.array([10, 20]), weights="area")
    assert 0.8 < index.grid.cell < 1.2  # (the distances above are in voxels of about 1 m)
    _assert_as_a_tree_finds(index)
    # the far points are what this is about: 6 shells settle neither their lists nor their second
    rows = index.rows_of(np.arange(20000, 20003))
    out = [np.empty((3, 20)), np.empty((3, 20), np.int64)] + [np.zeros(3, np.int64) for _ in "nt"] + [np.zeros(3, bool)]
    index.grid.search(rows, *out, ks=np.array([20]), s_max=6)
    third, done = np.empty(3), np.zeros(3, bool)
    index.grid.third_distances(rows, third, done, s_max=6)
    assert not out[-1].any() and not done.any()
    assert bool(completed) != farther, completed


@pytest.mark.parametrize("n", [2, 3])
def test_second_distances_of_a_few_far_apart_points(n):
    # so far apart that no voxel shell around one point reaches another: the farthest then
    xyz = np.array([[0.0, 0.0, 0.0], [1000.0, 0.0, 0.0], [0.0, 3000.0, 0.0]])[:n]
    index = NeighborIndex(xyz, "knn", np.array([n]))
    d = np.linalg.norm(index.xyz[:, None] - index.xyz[None], axis=2)
    np.testing.assert_allclose(index.second_distances(), np.sort(d, axis=1)[:, n - 1], rtol=1e-12)


def test_reach_holds_the_neighbourhood_and_no_point_beyond_can_join(pts):
    # what a tile's halo is checked against: every neighbour lies within the reach, and a
    # point beyond it is farther than the tie rule lets in (brute-force distances)
    for kind, scales in (("knn", np.array([5, 12])), ("radius", np.array([0.4, 0.9]))):
        index = NeighborIndex(pts, kind, scales, min_neighbors=1)
        rows = np.arange(0, 3000, 29)
        batch = index.query(rows)
        reach = batch.reach()
        for b, row in enumerate(rows):
            d = np.linalg.norm(index.xyz - index.xyz[row], axis=1)
            assert (batch.dist[b, :batch.n[b]] <= reach[b]).all()
            largest = np.sort(d)[scales[-1] - 1] if kind == "knn" else scales[-1]
            assert reach[b] >= largest * np.sqrt(1 + TIE) * (1 - 1e-12)  # a tied point is within reach
        if kind == "radius":
            np.testing.assert_allclose(reach, scales[-1] * np.sqrt(1 + TIE), rtol=1e-15)


def test_spherical_cap_keeps_nearest_and_is_reported(pts):
    index = NeighborIndex(pts, "radius", np.array([3.0]), max_neighbors=20, min_neighbors=1)
    batch = index.query(np.arange(10))
    assert (batch.counts[:, 0] == 20).all()
    assert batch.capped.all()
    d = np.linalg.norm(index.xyz[None, :, :] - index.xyz[:10, None, :], axis=2)
    np.testing.assert_allclose(np.sort(batch.dist[:, :20], axis=1), np.sort(d, axis=1)[:, :20])


def test_scales_below_min_neighbors_are_undefined(pts):
    index = NeighborIndex(pts, "radius", np.array([1e-6, 1.0]), min_neighbors=3)
    batch = index.query(np.arange(20))
    assert (batch.counts[:, 0] == 0).all() and (batch.counts[:, 1] >= 3).all()


def test_multiscale_averages_defined_scales_only():
    per = np.array([[[0.2, 0.7, 0.1], [np.nan] * 3, [0.4, 0.5, 0.1]]])
    sal, chosen = get_strategy("multiscale").combine(per)
    np.testing.assert_allclose(sal, [[0.3, 0.6, 0.1]])
    assert chosen is None


def test_multiscale_average_is_numpys_nanmean_to_the_bit():
    # the one-pass kernel adds the scales in numpy's order, so the averages are its own, not close
    rng = np.random.default_rng(3)
    for n_scales in (1, 3, 10):
        per = rng.random((5000, n_scales, 3))
        per[rng.random(per.shape[:2]) < 0.3] = np.nan  # undefined scales
        per[:7] = np.nan  # rows undefined at every scale
        with np.errstate(invalid="ignore"), pytest.warns(RuntimeWarning):
            expected = np.nanmean(per, axis=1)
        sal, _ = get_strategy("multiscale").combine(per)
        assert np.array_equal(sal, expected, equal_nan=True)
        assert np.isnan(sal[:7]).all()


def test_knn_counts_take_every_neighbour_tied_with_the_kth():
    # a lattice, where many points lie at exactly the k-th distance: each scale must hold them all
    g = np.arange(10, dtype=float)
    xyz = np.stack(np.meshgrid(g, g, g[:3], indexing="ij"), -1).reshape(-1, 3)
    ks = np.array([6, 12])
    index = NeighborIndex(xyz, "knn", ks, min_neighbors=1)
    batch = index.query(np.arange(len(xyz)))
    d2 = ((index.xyz[:, None, :] - index.xyz[None, :, :]) ** 2).sum(-1)
    kth = np.sort(d2, axis=1)[:, ks - 1]
    within = (d2[:, :, None] <= kth[:, None, :] * (1 + TIE)).sum(1)
    held = within <= ks.max() + 8  # ties the search's slack can hold
    assert held.all(axis=1).mean() > 0.9 and (within[held] > np.broadcast_to(ks, within.shape)[held]).any()
    assert np.array_equal(batch.counts[held], within[held])
    np.testing.assert_allclose(batch.sigma, np.sqrt(kth), rtol=1e-15)


def test_optimal_scale_picks_minimum_entropy_first_on_ties():
    per = np.array([[[0.5, 0.5, 0.0], [0.9, 0.1, 0.0], [0.1, 0.9, 0.0], [np.nan] * 3]])
    sal, chosen = get_strategy("optimal").combine(per)
    e = geometric_entropy(per[0, :3])
    assert chosen[0] == int(np.argmin(e)) == 1  # entropies of scales 1 and 2 tie; first wins
    np.testing.assert_allclose(sal[0], per[0, 1])


def test_optimal_scale_result_reports_chosen_scale():
    xyz, labels = airborne_like(2000)
    result = ls.Pipeline(strategy="optimal").run(ls.PointCloud(xyz, labels))
    chosen = result.saliency.optimal_scale
    assert chosen.shape == (2000,) and chosen.min() >= 0 and chosen.max() <= 9
    assert len(np.unique(chosen)) > 1


def test_unknown_plugin_lists_available():
    with pytest.raises(ls.LidarSigError, match="available: .*c3dcm"):
        ls.Pipeline(descriptor="nope")
    with pytest.raises(ls.LidarSigError, match="multiscale, optimal"):
        ls.Pipeline(strategy="nope")


def test_scales_validation():
    with pytest.raises(ls.LidarSigError):
        ls.radii(-1.0)
    with pytest.raises(ls.LidarSigError):
        ls.knn(1)
    assert ls.radii(0.011, 0.009, 0.010).values == (0.009, 0.010, 0.011)


@pytest.mark.parametrize("cell", [0.25, 0.5, 1.0, 3.0])
def test_second_distances_on_a_lattice_whose_points_lie_on_voxel_faces(cell):
    # a lattice of step 0.25 with the voxel side a multiple of it: many points sit exactly on a
    # face, and their second neighbour in the voxel next door must not be skipped for round-off
    from lidar_sig.numerics._voxels import VoxelGrid

    g = np.arange(0.0, 6.0, 0.25)
    xyz = np.array(np.meshgrid(g, g, [0.0, 0.25]), dtype=np.float64).reshape(3, -1).T
    xyz += np.random.default_rng(5).normal(0.0, 1e-3, xyz.shape) * (np.arange(len(xyz)) % 3 == 0)[:, None]
    grid = VoxelGrid(xyz, cell)
    third, done = np.empty(len(xyz)), np.zeros(len(xyz), np.bool_)
    grid.third_distances(np.arange(len(xyz)), third, done, s_max=6)
    ref, _ = cKDTree(grid.points).query(grid.points, k=3)
    assert done.all()
    np.testing.assert_allclose(np.sqrt(third), ref[:, 2], rtol=1e-12)
