"""Signatures (SPEC 5): frame, count rasters, renderings."""
import numpy as np
import pytest

import lidar_sig as ls
from lidar_sig.method.classes import ASPRS, PAPER, UNLABELED
from lidar_sig.method.signature_raster import Frame, Signature


def _sig(sal, labels, classes=ASPRS, frame=None):
    return Signature.from_saliency(sal, classes.index(labels), classes=classes, frame=frame)


def test_vertices_receive_pure_saliencies():
    frame = Frame()
    sal = np.eye(3)  # pure line, surface, point
    rows, cols = frame.pixels(sal)
    v = frame.vertices
    assert rows[0] < rows[1] == rows[2]          # line vertex at the top
    assert cols[2] < cols[0] < cols[1]           # point bottom-left, surface bottom-right
    np.testing.assert_allclose(np.linalg.norm(v[0] - v[1]), np.linalg.norm(v[1] - v[2]))
    mask = frame.mask()
    assert mask[rows, cols].all() and not mask[0, 0] and not mask[-1, -1]


def test_every_saliency_lands_inside_the_mask():
    sal = np.random.default_rng(0).dirichlet([0.3, 0.3, 0.3], 100000)
    rows, cols = Frame().pixels(sal)
    assert Frame().mask()[rows, cols].all()


def test_counts_are_additive_over_disjoint_parts():
    rng = np.random.default_rng(1)
    sal = rng.dirichlet([1, 1, 1], 5000)
    labels = rng.choice([2, 5, 6], 5000)
    whole = _sig(sal, labels)
    parts = _sig(sal[:2000], labels[:2000]) + _sig(sal[2000:], labels[2000:])
    assert np.array_equal(whole.counts, parts.counts)
    assert np.array_equal(whole.egeom_counts, parts.egeom_counts)
    assert whole.class_counts[[2, 5, 6]].tolist() == [np.sum(labels == c) for c in (2, 5, 6)]


def test_the_sum_of_two_signatures_adds_their_counts_of_points_left_out():
    # the sum kept the first term's n_excluded: an archive of a sum said too few were left out
    rng = np.random.default_rng(2)
    sal = rng.dirichlet([1, 1, 1], 100)
    a, b = _sig(sal[:60], np.full(60, 2)), _sig(sal[60:], np.full(40, 2))
    a.metadata.update(n_excluded=3, n_duplicates=1, descriptor="c3dcm")
    b.metadata.update(n_excluded=4, n_duplicates=0, descriptor="c3dcm")
    total = a + b
    assert total.metadata["n_excluded"] == 7 and total.metadata["n_duplicates"] == 1
    assert total.metadata["descriptor"] == "c3dcm" and a.metadata["n_excluded"] == 3  # terms unchanged


def test_signature_is_independent_of_point_order():
    rng = np.random.default_rng(2)
    sal = rng.dirichlet([1, 1, 1], 3000)
    labels = rng.choice([2, 6], 3000)
    order = rng.permutation(3000)
    assert np.array_equal(_sig(sal, labels).counts, _sig(sal[order], labels[order]).counts)


@pytest.mark.parametrize("mode", ["smooth", "density"])
def test_share_renderings_ignore_point_count(mode):
    rng = np.random.default_rng(3)
    sal = rng.dirichlet([1, 2, 1], 2000)
    labels = rng.choice([2, 6], 2000)
    one = _sig(sal, labels)
    twice = _sig(np.vstack([sal, sal]), np.concatenate([labels, labels]))
    np.testing.assert_allclose(one.sg(mode), twice.sg(mode))
    np.testing.assert_allclose(one.sas(mode), twice.sas(mode))
    assert one.sg(mode).max() <= 1 and one.sas(mode).min() >= 0


def test_points_rendering_marks_occupied_pixels_and_smooth_covers_them():
    rng = np.random.default_rng(3)
    sig = _sig(rng.dirichlet([1, 2, 1], 2000), rng.choice([2, 6], 2000))
    occupied = sig.total > 0
    assert set(np.unique(sig.sg("points"))) == {0.0, 1.0}
    assert np.array_equal(sig.sg("points") > 0, occupied)
    assert np.array_equal(sig.sg("density") > 0, occupied)
    # the smoothed density spreads each point over its neighbourhood: every occupied pixel and
    # more are lit, and Sas is coloured wherever the smoothed share reaches the floor
    assert (sig.sg("smooth")[occupied] > 0).all() and (sig.sg("smooth") > 0).sum() > occupied.sum()
    coloured = (sig.sas("smooth") < 1).any(axis=2)
    assert coloured[occupied].mean() > 0.99 and coloured.sum() > occupied.sum()


def test_smooth_rendering_is_robust_to_thinning():
    # the reason it is the default: a random half of the points changes the smoothed Sg far
    # less than the per-pixel renderings (relative L1 difference of the images)
    rng = np.random.default_rng(4)
    sal = rng.dirichlet([0.6, 3, 0.5], 20000)
    labels = rng.choice([2, 6], 20000)
    full, half = _sig(sal, labels), _sig(sal[::2], labels[::2])
    change = {m: np.abs(full.sg(m) - half.sg(m)).sum() / full.sg(m).sum() for m in ("smooth", "points", "density")}
    assert change["smooth"] < 0.5 * min(change["points"], change["density"])


def test_sas_mixes_class_colours_by_count():
    sal = np.tile([[0.2, 0.5, 0.3]], (4, 1))
    sig = _sig(sal, np.array([6, 6, 6, 5]), classes=PAPER)
    r, c = Frame().pixels(sal[:1])
    colors = PAPER.class_colors
    mean = (3 * colors[1] + colors[0]) / 4  # building x3, tree x1
    v = sig.sg("density")[r[0], c[0]]
    np.testing.assert_allclose(sig.sas("density")[r[0], c[0]], 1 - v * (1 - mean))
    np.testing.assert_allclose(sig.sas("points")[r[0], c[0]], mean)
    np.testing.assert_allclose(sig.sas("smooth")[r[0], c[0]], mean)  # full strength


def test_class_tables_map_codes_and_other():
    assert ASPRS.index(np.array([2, 6, 64, 18])).tolist() == [2, 6, len(ASPRS) - 1, 18]
    assert PAPER.index(np.array([4, 5, 6, 3, 2, 11, 1])).tolist() == [0, 0, 1, 2, 3, 3, 4]
    assert UNLABELED.index(np.array([1, 2])).tolist() == [0, 0]


def test_unlabeled_cloud_gives_geometric_metrics_only():
    rng = np.random.default_rng(4)
    xyz = rng.uniform(0, 20, (2000, 3)) * [1, 1, 0.05]
    res = ls.Pipeline(scales=ls.knn(10, 20)).run(ls.PointCloud(xyz))
    assert res.signature.classes == UNLABELED
    out = ls.compare(res.signature, res.signature)
    assert out["kl"] is None and out["l1"] is None and out["ssim"] == 1.0


def test_write_png(tmp_path):
    rng = np.random.default_rng(5)
    xyz = rng.uniform(0, 20, (2000, 3)) * [1, 1, 0.05]
    res = ls.Pipeline(scales=ls.knn(10)).run(ls.PointCloud(xyz, rng.choice([2, 6], 2000)))
    res.write(tmp_path / "s.png")
    import cv2

    from lidar_sig.reporting.render import signature_image
    img = cv2.imread(str(tmp_path / "s.png"), cv2.IMREAD_UNCHANGED)[..., ::-1]  # BGR -> RGB
    assert img.shape[1:] == (512, 3) and img.shape[0] > 512
    assert np.array_equal(img[:512], signature_image(res.signature))  # PNG is lossless
    # below Sas, the legend of its two classes: a swatch of each class's colour
    legend = img[512:]
    for k in np.flatnonzero(res.signature.class_counts > 0):
        colour = np.round(res.signature.classes.class_colors[k] * 255).astype(np.uint8)
        assert (legend == colour).all(axis=2).sum() >= 100, res.signature.classes.class_names[k]
    assert len(np.flatnonzero(res.signature.class_counts > 0)) == 2
    with pytest.raises(ls.LidarSigError, match="overwrite=True"):
        res.write(tmp_path / "s.png")


def test_user_class_tables_from_toml_and_json(tmp_path):
    from lidar_sig.method.classes import ISPRS_VAIHINGEN, class_table

    toml = tmp_path / "ign.toml"
    toml.write_text('name = "ign"\n[[class]]\nname = "vegetation"\ncodes = [3, 4, 5]\ncolor = [20, 140, 40]\n'
                    '[[class]]\nname = "ground"\ncodes = 2\ncolor = [120, 120, 120]\n')
    table = class_table(str(toml))
    assert table.class_names == ("vegetation", "ground", "other")
    assert table.index(np.array([3, 4, 5, 2, 6])).tolist() == [0, 0, 0, 1, 2]
    js = tmp_path / "ign.json"
    js.write_text('{"name": "ign", "class": [{"name": "vegetation", "codes": [3, 4, 5], "color": [20, 140, 40]},'
                  ' {"name": "ground", "codes": [2], "color": [120, 120, 120]}]}')
    assert class_table(str(js)) == table
    assert len(ISPRS_VAIHINGEN) == 10 and ISPRS_VAIHINGEN.index(np.array([8]))[0] == 8
    assert table.noise == () and ISPRS_VAIHINGEN.noise == ()  # noise codes only where declared
    noisy = tmp_path / "noisy.toml"
    noisy.write_text('name = "ign"\nnoise = [7, 18]\n' + toml.read_text().split("\n", 1)[1])
    assert class_table(str(noisy)).noise == (7, 18) and class_table(str(noisy)) != table


@pytest.mark.parametrize("text", ['name = "x"\n', '[[class]]\nname = "a"\ncodes = [1]\ncolor = [1, 2]\n',
                                  "not toml at all [[[", '[[class]]\nname="a"\ncodes=[1]\ncolor=[1,2,3]\n'
                                  '[[class]]\nname="b"\ncodes=[1]\ncolor=[1,2,3]\n',
                                  'noise = 7\n[[class]]\nname="a"\ncodes=[1]\ncolor=[1,2,3]\n',
                                  'noise = [0]\n[[class]]\nname="a"\ncodes=[1]\ncolor=[1,2,3]\n'])
def test_bad_class_tables_name_the_file(tmp_path, text):
    from lidar_sig.method.classes import class_table

    path = tmp_path / "bad.toml"
    path.write_text(text)
    with pytest.raises(ls.LidarSigError, match="bad.toml"):
        class_table(str(path))


def test_a_run_makes_its_signature_when_asked_and_pickles_either_way():
    # Pipeline.run leaves the signature to its first use (writing the points needs none); the
    # Result must still cross a process boundary (a process pool's map of Pipeline.run)
    import pickle

    rng = np.random.default_rng(11)
    xyz = rng.uniform(0, 20, (4000, 3)) * [1, 1, 0.2]
    labels = rng.choice([2, 6], 4000)
    result = ls.Pipeline(progress=False).run(xyz, labels=labels)
    result.metadata["added later"] = True  # the signature keeps the run's metadata as it was
    sent = pickle.loads(pickle.dumps(result))  # before the signature is made
    sig = result.signature
    assert sig is result.signature and "added later" not in sig.metadata
    eager = Signature.from_saliency(result.saliency.values, ASPRS.index(labels), classes=ASPRS,
                                    egeom=result.saliency.egeom)
    for got in (sig, sent.signature, pickle.loads(pickle.dumps(result)).signature):
        np.testing.assert_array_equal(got.counts, eager.counts)
        np.testing.assert_array_equal(got.class_totals, eager.class_totals)
    given = ls.Result(result.cloud, result.saliency, sig, result.metadata)  # a signature given as before
    assert given.signature is sig
    with pytest.raises(ls.LidarSigError):
        ls.Result(result.cloud, result.saliency)
