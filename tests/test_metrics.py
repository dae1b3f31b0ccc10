"""Comparison metrics (SPEC 6) against the paper's numbers and reference implementations."""
import numpy as np
import pytest
from scipy.stats import wasserstein_distance

import lidar_sig as ls
from conftest import airborne_like
from lidar_sig.metrics import (bhattacharyya, color_bin_centres, color_histogram, emd_img, emd_info,
                               fisher_vector, fv_distance, l1_distance, ssim, symmetric_kl)
from lidar_sig.method.saliency_map import LN3

AREA2 = [107485, 69097, 38866, 51227]  # paper Table 1: tree, building, low vegetation, road
AREA3 = [135449, 69563, 35512, 83372]


def test_table1_symmetric_kl_and_l1():
    # The paper prints 0.0382 and 0.1609; the exact values are 0.038267 and 0.160878.
    assert symmetric_kl(AREA2, AREA3) == pytest.approx(0.0382, abs=1e-4)
    assert l1_distance(AREA2, AREA3) == pytest.approx(0.1609, abs=1e-4)


def test_kl_is_symmetric_and_finite_with_empty_classes():
    p, q = [10, 0, 5, 0], [3, 4, 5, 0]
    assert symmetric_kl(p, q) == pytest.approx(symmetric_kl(q, p))
    assert np.isfinite(symmetric_kl(p, q)) and symmetric_kl(p, q) > 0
    assert symmetric_kl(p, p) == 0.0 and l1_distance(p, p) == 0.0


def test_emd_info_equals_scipy_wasserstein_of_binned_histograms():
    rng = np.random.default_rng(0)
    a, _ = np.histogram(rng.uniform(0, LN3, 5000) ** 1.3, bins=100, range=(0, LN3))
    b, _ = np.histogram(rng.uniform(0, LN3, 3000), bins=100, range=(0, LN3))
    centres = (np.arange(100) + 0.5) * LN3 / 100
    ref = wasserstein_distance(centres, centres, a, b)
    assert emd_info(a, b) == pytest.approx(ref, rel=1e-12)
    assert emd_info(b, a) == pytest.approx(ref, rel=1e-12)


def test_ssim_matches_scikit_image_over_mask():
    structural_similarity = pytest.importorskip("skimage.metrics").structural_similarity
    rng = np.random.default_rng(1)
    a = rng.uniform(0, 1, (64, 64))
    b = np.clip(a + 0.2 * rng.standard_normal((64, 64)), 0, 1)
    mask = np.zeros((64, 64), bool)
    mask[10:50, 12:40] = True
    _, full = structural_similarity(a, b, data_range=1.0, gaussian_weights=True, sigma=1.5,
                                    use_sample_covariance=False, full=True)
    assert ssim(a, b, mask) == pytest.approx(full[mask].mean(), rel=1e-9)
    assert ssim(a, a, mask) == pytest.approx(1.0)


def test_bhattacharyya_matches_opencv():
    cv2 = pytest.importorskip("cv2")
    rng = np.random.default_rng(2)
    a = rng.uniform(0, 1, (40, 40, 3))
    b = rng.uniform(0, 1, (40, 40, 3)) ** 2
    mask = np.ones((40, 40), bool)
    mask[:5] = False
    ha, hb = color_histogram(a, mask), color_histogram(b, mask)

    def cv_hist(img):
        u8 = np.clip(np.rint(img * 255), 0, 255).astype(np.uint8)
        return cv2.calcHist([u8], [0, 1, 2], mask.astype(np.uint8), [8, 8, 8], [0, 256] * 3)

    ref = cv2.compareHist(cv_hist(a), cv_hist(b), cv2.HISTCMP_BHATTACHARYYA)
    assert bhattacharyya(ha, hb) == pytest.approx(ref, abs=1e-6)
    assert bhattacharyya(ha, ha) == pytest.approx(0.0, abs=1e-7)


@pytest.mark.parametrize("hist", [np.ones(7), np.arange(1.0, 7.0)])
def test_bhattacharyya_of_a_histogram_with_itself_is_exactly_zero(hist):
    # 1 - sum sqrt(h h) is a few 1e-16 for these (not 0), which a square root lifts to 1e-8;
    # the distance of equal inputs is 0 exactly on every CPU (a sum of zero terms)
    assert bhattacharyya(hist, hist) == 0.0
    assert bhattacharyya(hist, 2 * hist) == 0.0  # the same shape: normalized alike, exactly
    # the other form of the same quantity, for two different histograms
    other = hist + np.arange(len(hist)) ** 2
    p, q = hist / hist.sum(), other / other.sum()
    assert bhattacharyya(hist, other) == pytest.approx(np.sqrt(1 - np.sum(np.sqrt(p * q))), rel=1e-9)


def test_compare_identity_and_ranges():
    xyz, labels = airborne_like(3000, seed=1)
    xyz2, labels2 = airborne_like(3000, seed=2)
    pipe = ls.Pipeline(scales=ls.radii(1.0, 1.5, units="metric"))
    sa = pipe.run(ls.PointCloud(xyz, labels)).signature
    sb = pipe.run(ls.PointCloud(xyz2 * [1, 1, 1.5], labels2)).signature
    same = ls.compare(sa, sa)
    assert same == {"bhattacharyya": 0.0, "ssim": 1.0, "emd_info": 0.0, "emd_img": 0.0, "fv": 0.0,
                    "kl": 0.0, "l1": 0.0}
    diff = ls.compare(sa, sb)
    assert 0 < diff["bhattacharyya"] <= 1 and -1 <= diff["ssim"] < 1 and diff["emd_info"] > 0
    assert 0 < diff["emd_img"] <= np.sqrt(3) and 0 < diff["fv"] <= 2
    back = ls.compare(sb, sa)
    for key in ("bhattacharyya", "emd_info", "emd_img", "fv", "kl", "l1"):
        assert back[key] == pytest.approx(diff[key], rel=1e-9, abs=1e-12), key


def test_compare_refuses_different_frames():
    xyz, labels = airborne_like(1000)
    cloud = ls.PointCloud(xyz, labels)
    sa = ls.Pipeline(scales=ls.radii(1.5, units="metric")).run(cloud).signature
    sb = ls.Pipeline(scales=ls.radii(1.5, units="metric"), frame=ls.Frame(256)).run(cloud).signature
    with pytest.raises(ls.LidarSigError, match="different frames"):
        ls.compare(sa, sb)


def test_emd_img_moves_mass_by_colour_distance():
    bins = 8
    centres = color_bin_centres(bins)
    a = np.zeros(bins ** 3)
    b = np.zeros(bins ** 3)
    a[0], b[7] = 1.0, 1.0  # same red and green bin, blue bin 0 against 7
    assert emd_img(a, b) == pytest.approx(np.linalg.norm(centres[0] - centres[7]), rel=1e-6)
    assert emd_img(a, b) == pytest.approx(emd_img(b, a), rel=1e-9)
    assert emd_img(a, a) == 0.0


def test_fisher_vector_is_normalized_and_separates_distributions():
    rng = np.random.default_rng(3)
    near_cs = np.column_stack([rng.uniform(0.7, 0.95, 500), rng.uniform(0.0, 0.1, 500)])
    near_cl = np.column_stack([rng.uniform(0.45, 0.55, 500), rng.uniform(0.6, 0.8, 500)])
    w = np.ones(500)
    fa, fb = fisher_vector(near_cs, w), fisher_vector(near_cl, w)
    assert np.linalg.norm(fa) == pytest.approx(1.0)
    d_far = np.linalg.norm(fa - fb)
    d_near = np.linalg.norm(fa - fisher_vector(near_cs + 0.01, w))
    assert 0 < d_near < d_far <= 2
    # weights act like repeated points
    assert np.allclose(fisher_vector(near_cs[:2], [2, 1]), fisher_vector(near_cs[[0, 0, 1]], [1, 1, 1]))


def test_fv_distance_of_signatures_is_symmetric():
    xyz, labels = airborne_like(2000, seed=3)
    pipe = ls.Pipeline(scales=ls.radii(1.0, 1.5, units="metric"))
    sa = pipe.run(ls.PointCloud(xyz, labels)).signature
    sb = pipe.run(ls.PointCloud(xyz * [1, 1, 2], labels)).signature
    assert fv_distance(sa, sb) == pytest.approx(fv_distance(sb, sa), rel=1e-12)
    assert fv_distance(sa, sa) == 0.0


def test_opencv_colour_histogram_equals_numpy_binning_of_the_8_bit_image():
    """color_histogram uses OpenCV's calcHist; the definition is numpy's 3-D histogram of the
    8-bit values over [0, 256) with `bins` equal bins per channel, R major."""
    rng = np.random.default_rng(7)
    rgb = rng.uniform(0, 1, (64, 48, 3)) ** 1.7
    mask = rng.uniform(0, 1, (64, 48)) > 0.3
    u8 = np.clip(np.rint(rgb * 255), 0, 255)[mask]
    for bins in (4, 8, 16):
        ref, _ = np.histogramdd(u8, bins=bins, range=[(0, 256)] * 3)
        assert np.array_equal(color_histogram(rgb, mask, bins=bins), ref.ravel() / mask.sum())
    whole, _ = np.histogramdd(np.clip(np.rint(rgb * 255), 0, 255).reshape(-1, 3), bins=8, range=[(0, 256)] * 3)
    assert np.array_equal(color_histogram(rgb), whole.ravel() / whole.sum())


def test_opencv_gaussian_blur_equals_scipy_gaussian_filter():
    """The SSIM's window goes through OpenCV; scipy's gaussian_filter is the definition
    (and what scikit-image's SSIM uses)."""
    from scipy.ndimage import gaussian_filter

    from lidar_sig.metrics import gaussian_blur

    rng = np.random.default_rng(8)
    img = rng.uniform(0, 1, (120, 90))
    for sigma in (0.8, 1.5, 3.0):
        ref = gaussian_filter(img, sigma, truncate=3.5, mode="reflect")
        assert np.abs(gaussian_blur(img, sigma) - ref).max() < 1e-12


def test_comparing_clouds_leaves_them_unchanged():
    # one cloud unlabelled: both are compared as one class, but the caller's clouds keep theirs
    xyz, labels = airborne_like(1500, seed=5)
    xyz2, _ = airborne_like(1500, seed=6)
    pipe = ls.Pipeline(scales=ls.knn(10, 20), progress=False)
    labelled, bare = ls.PointCloud(xyz.copy(), labels.copy()), ls.PointCloud(xyz2.copy())
    unlabelled_archive = pipe.run(ls.PointCloud(xyz2)).signature
    for run in (lambda: ls.compare_sources(labelled, bare, pipe),
                lambda: ls.compare_sources(bare, labelled, pipe),
                lambda: ls.compare_sources(labelled, unlabelled_archive, pipe),
                lambda: ls.report(labelled, bare, pipe)):
        out = run()
        assert labelled.labels is not None and np.array_equal(labelled.labels, labels)
        assert np.array_equal(labelled.xyz, xyz) and np.array_equal(bare.xyz, xyz2) and bare.labels is None
    assert out is not None and ls.compare_sources(labelled, bare, pipe).metrics["kl"] is None


def test_values_of_the_wrong_kind_are_named_with_their_article():
    # "a int" was said where a number came instead of a cloud, a source or a signature
    from lidar_sig.comparison import compare_sources
    from lidar_sig.base.errors import a_kind

    assert [a_kind(v) for v in (None, 3, "x", [1], object())] == ["None", "an int", "a str", "a list", "an object"]
    with pytest.raises(ls.LidarSigError, match="cannot run on an int"):
        ls.Pipeline(progress=False).run(3)
    with pytest.raises(ls.LidarSigError, match="a is an int"):
        compare_sources(3, 4)
    with pytest.raises(ls.LidarSigError, match="b is an int"):
        ls.compare(ls.Pipeline(progress=False).run(ls.PointCloud(*airborne_like(2000))).signature, 3)
