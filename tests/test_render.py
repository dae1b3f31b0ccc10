"""Pictures drawn with OpenCV: signature images, the difference of two signatures, the top
view, PNG encoding."""
import numpy as np
import pytest

import lidar_sig as ls
from conftest import airborne_like
from lidar_sig.reporting import render


@pytest.fixture(scope="module")
def two():
    pipe = ls.Pipeline(scales=ls.knn(10, 20))
    xyz, labels = airborne_like(3000, seed=1)
    xyz2, labels2 = airborne_like(3000, seed=2)
    return pipe.run(ls.PointCloud(xyz, labels)), pipe.run(ls.PointCloud(xyz2 * [1, 1, 1.6], labels2))


def test_png_encoding_is_lossless():
    import cv2

    rng = np.random.default_rng(0)
    rgb = rng.integers(0, 256, (37, 53, 3), dtype=np.uint8)
    back = cv2.imdecode(np.frombuffer(render.encode_png(rgb), np.uint8), cv2.IMREAD_COLOR)[..., ::-1]
    assert np.array_equal(back, rgb)


def test_signature_image_is_white_outside_the_triangle_and_labels_the_vertices(two):
    sig = two[0].signature
    img = render.signature_image(sig)
    outside = ~sig.frame.mask()
    # the labels are drawn outside the triangle, near each vertex: dark pixels there
    v = sig.frame.vertices
    for x, y, dx, dy in ((v[0, 0], v[0, 1], 0, -12), (v[1, 0], v[1, 1], -25, 14), (v[2, 0], v[2, 1], 15, 14)):
        patch = img[int(y + dy) - 8:int(y + dy) + 8, int(x + dx) - 25:int(x + dx) + 25]
        assert (patch.min(axis=2) < 120).sum() > 10
    import cv2

    near_edge = cv2.dilate(sig.frame.mask().astype(np.uint8), np.ones((7, 7), np.uint8)).astype(bool)
    far = outside & ~near_edge  # away from the anti-aliased outline
    far[:80] = False
    far[430:] = False  # away from the labels
    assert far.sum() > 50_000 and (img[far] == 255).all()


def test_difference_is_antisymmetric_zero_for_itself_and_sums_to_zero(two):
    a, b = (r.signature for r in two)
    d = render.difference(a, b)
    assert np.allclose(render.difference(b, a), -d)
    assert np.abs(render.difference(a, a)).max() == 0
    assert abs(d.sum()) < 1e-6  # shares of each cloud sum to one (less what smoothing spills off the image)
    import cv2

    img = render.difference_image(a, a)
    inner = cv2.erode(a.frame.mask().astype(np.uint8), np.ones((7, 7), np.uint8)).astype(bool)  # not the outline
    assert (img[:a.frame.size][inner] == 247).all()  # the ramp's white: nothing changed


def test_top_view_shows_the_highest_point_of_each_cell():
    # two points per cell: the lower one is line-type, the upper surface-type
    g = np.arange(10) + 0.5
    x, y = np.meshgrid(g, g)
    low = np.column_stack([x.ravel(), y.ravel(), np.zeros(100)])
    high = low + [0, 0, 5]
    xyz = np.vstack([low, high])
    sal = np.vstack([np.tile([1.0, 0.0, 0.0], (100, 1)), np.tile([0.0, 1.0, 0.0], (100, 1))])
    raster, cell = render.top_view(xyz, sal, points_per_cell=2.0)
    assert cell == pytest.approx(np.sqrt(9 * 9 * 2 / 200))
    assert (raster.reshape(-1, 3) == [0, 255, 0]).all(axis=1).all()
    sal[100:] = np.nan  # undefined on top: grey
    raster, _ = render.top_view(xyz, sal, points_per_cell=2.0)
    assert (raster.reshape(-1, 3) == render.UNDEFINED_GREY).all()


def test_top_view_stays_small_for_a_million_points():
    rng = np.random.default_rng(3)
    xyz = rng.uniform(0, 1000, (1_000_000, 3))
    sal = rng.dirichlet([1, 1, 1], 1_000_000)
    raster, _ = render.top_view(xyz, sal)
    assert max(raster.shape[:2]) <= 900
    assert len(render.encode_png(render.top_view_image(xyz, sal))) < 3_000_000


def test_top_views_drawn_with_one_span_share_one_scale():
    rng = np.random.default_rng(3)
    big = rng.uniform(0, 200, (40_000, 3))
    small = big[(big[:, 0] < 100) & (big[:, 1] < 100)]  # a quarter: half as wide
    sal = np.full((len(big), 3), 1 / 3)
    alone = render.top_view_image(small, sal[:len(small)])
    shared = render.top_view_image(small, sal[:len(small)], span=200.0)
    full = render.top_view_image(big, sal, span=200.0)
    key = render.top_view_image(big, sal).shape[1] - 640  # the key panel beside the view
    assert abs((alone.shape[1] - key) - 640) <= 2  # alone, a cloud fills the width
    # with the span of the larger cloud, the smaller one is drawn half as wide
    assert abs((shared.shape[1] - key) / (full.shape[1] - key) - 0.5) < 0.02
