"""The change map (issue 13): per-cell signatures and metrics on a grid of the CRS, its ranking on
known changes, the GeoTIFF, the command line and its refusals."""
import importlib.util
import json
import shutil
import subprocess
import sys

import numpy as np
import pytest

import lidar_sig as ls
from conftest import IGN, ROOT, SAMPLES, airborne_like, need_data
from lidar_sig.change_map import THRESHOLDS, Grid, changes
from lidar_sig.cloud import PointCloud
from lidar_sig.errors import LidarSigError
from robustness.helpers import assert_one_line_error, leftovers, run

sys.path.insert(0, str(ROOT / "benchmarks"))
sys.path.insert(0, str(SAMPLES))
needs_rasterio = pytest.mark.skipif(importlib.util.find_spec("rasterio") is None,
                                    reason="rasterio not installed: pip install -e '.[geo]'")


ALIGNED = SAMPLES / "epoch2_aligned.laz"  # epoch 2 of the sample scene, not turned


def small_cloud(seed=0, crs="EPSG:2154", offset=(770_000.0, 6_277_000.0, 0.0)):
    xyz, labels = airborne_like(6000, seed=seed)
    return PointCloud(xyz + np.asarray(offset), labels, crs=crs)


# -- the grid ---------------------------------------------------------------------------------

def test_grid_is_aligned_to_multiples_of_the_cell_and_cells_are_half_open():
    xy = np.array([[1003.0, 2049.9], [1049.99, 2000.0], [1050.0, 2075.0]])
    g = Grid.covering(xy, 25.0)
    assert (g.x0, g.y0, g.rows, g.cols) == (1000.0, 2000.0, 4, 3)
    # (1050, 2075) starts a new column and row: [x0 + i s, x0 + (i + 1) s)
    assert g.cell_of(xy).tolist() == [2 * 3 + 0, 3 * 3 + 1, 0 * 3 + 2]  # row 0 is north
    assert g.transform == (25.0, 0.0, 1000.0, 0.0, -25.0, 2100.0)
    x_min, y_min, x_max, y_max = g.bounds(np.array([0, 11]))
    assert x_min.tolist() == [1000.0, 1050.0] and y_max.tolist() == [2100.0, 2025.0]


def test_every_point_falls_in_the_grid_where_the_division_rounds():
    # 27392.3 / 0.1 rounds up to a whole number, putting the floored corner past the point, and
    # Python's // disagrees with the floor of the division at 6706.2 / 0.1: both used to give
    # points outside the grid (cell -1) and a ValueError in the binning
    for xy in (np.array([[27392.3, 100.0], [27400.0, 101.0]]), np.array([[6700.0, 0.0], [6706.2, 3.0]])):
        g = Grid.covering(xy, 0.1)
        assert (g.cell_of(xy) >= 0).all() and g.x0 <= xy[:, 0].min()


def test_a_far_outlier_is_refused_in_one_line_before_the_saliency():
    a = small_cloud(0)
    far = PointCloud(np.vstack([a.xyz, a.xyz[:1] + [2e6, 2e6, 0.0]]), np.concatenate([a.labels, a.labels[:1]]),
                     crs=a.crs)
    with pytest.raises(LidarSigError, match="cells of 25 m.*outlying"):
        changes(far, small_cloud(1), cell=25)


def test_per_cell_signatures_add_up_to_the_whole_epoch():
    a, b = small_cloud(0), small_cloud(1)
    cm = changes(a, b, cell=10, min_points=1)
    whole = ls.Pipeline(frame=cm.frame).run(a).signature
    total = sum(cm.signatures(int(c))[0].counts for c in np.flatnonzero(cm.table["points_a"] > 0))
    assert np.array_equal(total, whole.counts)  # saliency of the whole epoch, binned: additive
    assert cm.table["points_a"].sum() == len(a) and cm.table["points_b"].sum() == len(b)
    assert (cm.classes_a.sum(axis=1) == cm.table["points_a"]).all()


def test_cell_size_is_in_metres_whatever_the_crs_unit():
    feet = small_cloud(0, crs="EPSG:2249", offset=(700_000.0, 2_900_000.0, 0.0))  # US survey feet
    cm = changes(feet, small_cloud(1, crs="EPSG:2249", offset=(700_000.0, 2_900_000.0, 0.0)), cell=10,
                 min_points=50)
    assert cm.grid.size == pytest.approx(10 / 0.3048006096, rel=1e-9)
    assert cm.grid.x0 % cm.grid.size == pytest.approx(0.0, abs=1e-6)


def test_refuses_epochs_in_different_crs_bad_cell_sizes_and_scores():
    a = small_cloud(0)
    with pytest.raises(LidarSigError, match="different CRS"):
        changes(a, small_cloud(1, crs="EPSG:32631"))
    with pytest.raises(LidarSigError, match="has no CRS while"):
        changes(a, small_cloud(1, crs=None))
    for cell in (0, -5, float("nan"), "25", True):
        with pytest.raises(LidarSigError, match="cell size"):
            changes(a, a, cell=cell)
    with pytest.raises(LidarSigError, match="unknown score"):
        changes(a, a, score="psnr")
    with pytest.raises(LidarSigError, match="no cell of 1 m holds"):
        changes(a, a, cell=1)


def test_unlabelled_epochs_rank_by_a_geometric_metric():
    a, b = small_cloud(0), small_cloud(1)
    a.labels = b.labels = None
    cm = changes(a, b, cell=10, min_points=100)
    assert cm.score == "emd_info" and np.isnan(cm.table["kl"]).all()
    valid = cm.table["valid"]
    assert np.array_equal(cm.table["score"][valid], cm.table["emd_info"][valid])


def test_one_unlabelled_epoch_is_said_not_shown_as_a_class_change():
    from lidar_sig.errors import LidarSigWarning

    a, b = small_cloud(0), small_cloud(1)
    b.labels = None
    with pytest.warns(LidarSigWarning, match="has no class labels.*geometry only"):
        cm = changes(a, b, cell=10, min_points=100)
    assert cm.score == "emd_info"


# -- must show 1: known edits of real data ----------------------------------------------------

@pytest.fixture(scope="module")
def ign_edited():
    need_data(IGN)
    from edited_epoch import edited_epochs

    one, two, edits = edited_epochs()
    cm = changes(one, two)
    edited = {int(cm.grid.cell_of(np.array([xy]))[0]) for xy in edits.values()}
    return cm, edited


def precision_recall(cm, edited, threshold):
    """Precision and recall over the compared cells of "score >= threshold" as "edited"."""
    valid = np.flatnonzero(cm.table["valid"])
    flagged = {int(c) for c in valid if cm.table["score"][c] >= threshold}
    hits = len(flagged & edited)
    return (hits / len(flagged) if flagged else 1.0), hits / len(edited)


def test_the_three_edited_cells_of_the_ign_block_rank_first(ign_edited):
    cm, edited = ign_edited
    assert len(edited) == 3 and cm.table["valid"][list(edited)].all()
    assert set(cm.ranked(3).tolist()) == edited
    score = cm.table["score"]
    others = np.flatnonzero(cm.table["valid"] & ~np.isin(np.arange(cm.grid.n_cells), list(edited)))
    assert len(others) >= 15
    assert score[others].max() < min(score[c] for c in edited)
    for t in THRESHOLDS:  # the figures docs/changes.md gives
        precision, recall = precision_recall(cm, edited, t)
        print(f"threshold {t}: precision {precision:.2f}, recall {recall:.2f}")
        assert precision == 1.0 and recall == 1.0, t


def test_ign_shift_and_thinning_alone_stay_below_the_lowest_threshold(ign_edited):
    cm, edited = ign_edited
    valid = cm.table["valid"] & ~np.isin(np.arange(cm.grid.n_cells), list(edited))
    assert cm.table["score"][valid].max() < THRESHOLDS[0]


# -- must show 2: the synthetic scene of data_samples -------------------------------------------

def coregistered_samples():
    """The two epochs of data_samples/make_scene.py without epoch 2's 20 degree rotation (the
    committed epoch2.laz is rotated about the scene centre to test rotation invariance, so its
    coordinates no longer describe the same ground as epoch 1's), and the changes' places."""
    import make_scene as ms

    scenes = ms.build_scenes()
    clouds = []
    for epoch in (1, 2):
        seed, density, _, _ = ms.EPOCHS[epoch]
        pts = ms.sample_scene(scenes[epoch], seed, density)
        xyz = np.column_stack([pts["x"] + ms.ORIGIN_X, pts["y"] + ms.ORIGIN_Y, pts["z"]])
        clouds.append(PointCloud(np.round(xyz, 2), pts["classification"].astype(np.int64), crs="EPSG:2154"))
    removed = [t for t in scenes[1].trees if t not in scenes[2].trees]
    trees = np.array([(ms.ORIGIN_X + t.x, ms.ORIGIN_Y + t.y) for t in removed])
    building = np.array([(ms.ORIGIN_X + ms.NEW_BUILDING.cx, ms.ORIGIN_Y + ms.NEW_BUILDING.cy)])
    return clouds, trees, building


def test_removed_trees_and_the_new_building_are_in_the_top_cells_of_the_sample_scene():
    (a, b), trees, building = coregistered_samples()
    cm = changes(a, b, cell=16, min_points=500)
    top = cm.ranked(3).tolist()
    building_cell = int(cm.grid.cell_of(building)[0])
    tree_cells = set(cm.grid.cell_of(trees).tolist())
    assert building_cell in top
    assert all(c in tree_cells or c == building_cell for c in top)
    assert cm.table["valid"].sum() >= 16


def test_committed_sample_pair_shows_the_cut_trees_and_the_new_building_in_its_top_cells():
    # epoch2_aligned.laz is epoch 2 on epoch 1's ground (epoch2.laz is turned by 20 degrees to
    # show that whole-cloud signatures do not depend on orientation: docs/changes.md)
    import make_scene as ms

    cm = changes(SAMPLES / "epoch1.laz", ALIGNED, cell=16, min_points=500)
    scenes = ms.build_scenes()
    removed = [t for t in scenes[1].trees if t not in scenes[2].trees]
    tree_cells = set(cm.grid.cell_of(np.array([(ms.ORIGIN_X + t.x, ms.ORIGIN_Y + t.y) for t in removed])).tolist())
    building_cell = int(cm.grid.cell_of(np.array([(ms.ORIGIN_X + ms.NEW_BUILDING.cx,
                                                   ms.ORIGIN_Y + ms.NEW_BUILDING.cy)]))[0])
    top = cm.ranked(3).tolist()
    assert building_cell in top and all(c in tree_cells or c == building_cell for c in top)
    assert int(cm.ranked(1)[0]) in tree_cells


# -- must show 3 and the command line ----------------------------------------------------------

@pytest.fixture(scope="module")
def sample_run(tmp_path_factory):
    pytest.importorskip("rasterio", reason="rasterio not installed: pip install -e '.[geo]'")
    out = tmp_path_factory.mktemp("changes")
    proc = run("changes", SAMPLES / "epoch1.laz", ALIGNED, "-o", out / "map.tif", "--cell", "16",
               "--min-points", "500", "--png", out / "map.png", "--report", out / "map.html", "--json", "--top", "30")
    assert proc.returncode == 0, proc.stderr
    return out, json.loads(proc.stdout)


def test_geotiff_has_the_crs_transform_band_names_and_no_data(sample_run):
    import rasterio

    out, info = sample_run
    with rasterio.open(out / "map.tif") as src:
        assert src.crs.to_epsg() == 2154
        a, b, c, d, e, f = tuple(src.transform)[:6]
        assert (a, b, d, e) == (16.0, 0.0, 0.0, -16.0)
        assert c % 16 == 0 and f % 16 == 0  # aligned to multiples of the cell size
        assert [a, b, c, d, e, f] == info["grid"]["transform"]
        assert src.nodata == -9999.0 and src.profile["compress"] == "deflate"
        names = src.descriptions
        assert names[0].startswith("score: delta_KL") and len(names) == 12
        assert {n.split(":")[0] for n in names[1:8]} == {"d_BD-Img", "s_SSIM", "d_EMD-Info", "d_EMD-Img",
                                                         "delta_FV", "delta_KL", "L1"}
        score, points_a = src.read(1), src.read(names.index("points of epoch A") + 1)
    assert (score == -9999.0).any() and (score != -9999.0).sum() == info["grid"]["valid"]
    for cell in info["top"]:  # the raster holds what the ranked list says, cell by cell
        assert score[cell["row"], cell["col"]] == pytest.approx(cell["score"], rel=1e-6)
        assert points_a[cell["row"], cell["col"]] == cell["points_a"]
        x0, y0, x1, y1 = cell["bounds"]
        assert (x0, y1) == (c + cell["col"] * 16, f - cell["row"] * 16) and x1 - x0 == 16
        assert sum(na for na, _ in cell["classes"].values()) == cell["points_a"]
    ranked = [cell["score"] for cell in info["top"]]
    assert ranked == sorted(ranked, reverse=True) and len(ranked) == info["grid"]["valid"]


@pytest.mark.skipif(shutil.which("gdalinfo") is None, reason="GDAL's gdalinfo is not installed")
def test_gdalinfo_reads_the_geotiff(sample_run):
    out, info = sample_run
    text = subprocess.run(["gdalinfo", str(out / "map.tif")], capture_output=True, text=True, check=True).stdout
    assert "Lambert-93" in text and "NoData Value=-9999" in text and "Description = score: delta_KL" in text
    assert f"Pixel Size = (16.000000000000000,-16.000000000000000)" in text


def test_png_map_and_html_report_are_written(sample_run):
    out, _ = sample_run
    assert (out / "map.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    html = (out / "map.html").read_text()
    assert html.count("data:image/png;base64,") == 2 + 2 * 5 and "Most changed cells" in html
    assert "http" not in html.replace("http-equiv", "")  # self-contained


def test_cli_prints_the_ranked_cells():
    proc = run("changes", SAMPLES / "epoch1.laz", ALIGNED, "--cell", "16", "--min-points", "500",
               "--top", "3", "-q")
    assert proc.returncode == 0, proc.stderr
    lines = proc.stdout.splitlines()
    assert lines[0].startswith("5 x 5 cells of 16 m") and "ranked by delta_KL" in lines[0]
    assert [line.split()[0] for line in lines[2:]] == ["1", "2", "3"]


def test_cli_refuses_epochs_in_different_crs_in_one_line(tmp_path):
    from edited_epoch import write_las

    import laspy

    las = laspy.read(SAMPLES / "epoch2.laz")
    cloud = PointCloud(np.column_stack([las.x, las.y, las.z]), np.asarray(las.classification), crs="EPSG:32631")
    write_las(cloud, tmp_path / "utm.laz")
    proc = run("changes", SAMPLES / "epoch1.laz", tmp_path / "utm.laz", "--png", tmp_path / "map.png")
    assert_one_line_error(proc, "utm.laz", "different CRS")
    assert not (tmp_path / "map.png").exists() and not leftovers(tmp_path)


def test_cli_refuses_bad_cell_size_and_unwritable_outputs_before_computing(tmp_path):
    for value in ("0", "-25", "inf"):
        proc = run("changes", SAMPLES / "epoch1.laz", SAMPLES / "epoch2.laz", "--cell", value,
                   "--png", tmp_path / "map.png")
        assert_one_line_error(proc, "cell size")
    proc = run("changes", SAMPLES / "epoch1.laz", SAMPLES / "epoch2.laz", "--png", tmp_path / "no" / "map.png")
    assert_one_line_error(proc, "map.png", "does not exist")
    proc = run("changes", SAMPLES / "epoch1.laz", SAMPLES / "epoch2.laz", "-o", tmp_path / "map.png")
    assert_one_line_error(proc, "map.png", ".tif")
    assert list(tmp_path.iterdir()) == []


def test_geotiff_without_rasterio_says_how_to_install_it(tmp_path, monkeypatch):
    monkeypatch.setitem(sys.modules, "rasterio", None)  # import rasterio now fails
    from lidar_sig.io.geotiff import check_geotiff_output

    with pytest.raises(LidarSigError, match=r"pip install lidar-sig\[geo\]"):
        check_geotiff_output(tmp_path / "map.tif")
    cm = changes(small_cloud(0), small_cloud(1), cell=10, min_points=100)
    with pytest.raises(LidarSigError, match=r"pip install lidar-sig\[geo\]"):
        cm.save(tmp_path / "map.tif")
    assert list(tmp_path.iterdir()) == []


def test_python_api_table_transform_and_ranking():
    cm = ls.changes(small_cloud(0), small_cloud(1), cell=10, min_points=100)
    t = cm.table
    assert t.dtype.names[:4] == ("row", "col", "x_min", "y_min") and len(t) == cm.grid.n_cells
    assert np.isnan(t["score"][~t["valid"]]).all() and not np.isnan(t["score"][t["valid"]]).any()
    transform = cm.transform
    assert tuple(transform)[:6] == cm.grid.transform
    order = cm.ranked()
    assert len(order) == t["valid"].sum() and (np.diff(t["score"][order]) <= 0).all()
    if importlib.util.find_spec("pandas"):
        assert len(cm.to_pandas()) == len(t)


def test_an_epoch_given_as_a_folder_of_tiles_is_joined_before_the_saliency(tmp_path):
    import laspy
    from edited_epoch import write_las

    las = laspy.read(SAMPLES / "epoch1.laz")
    xyz = np.column_stack([las.x, las.y, las.z])
    labels = np.asarray(las.classification).astype(np.int64)
    west = xyz[:, 0] < np.median(xyz[:, 0])
    (tmp_path / "tiles").mkdir()
    for name, part in (("west.laz", west), ("east.laz", ~west)):
        write_las(PointCloud(xyz[part], labels[part], crs="EPSG:2154"), tmp_path / "tiles" / name)
    whole = PointCloud(np.round(xyz, 3), labels, crs="EPSG:2154")
    cm = changes(tmp_path / "tiles", whole, cell=16, min_points=500)
    valid = cm.table["valid"]
    assert valid.sum() >= 16
    # same points, saliency across the tile edge as in the whole cloud: nothing changed anywhere
    assert np.array_equal(cm.table["points_a"], cm.table["points_b"])
    assert np.allclose(cm.table["kl"][valid], 0.0) and np.allclose(cm.table["fv"][valid], 0.0, atol=1e-12)


def test_cells_are_admitted_by_their_points_with_defined_saliency():
    # issue 16: spherical scales leave the points of a sparse cell undefined; a cell whose points
    # were all undefined was compared, raising a ValueError from its empty Egeom histogram
    def cloud(seed, dense=3000):
        rng = np.random.default_rng(seed)
        side = 10.0 if dense > 100 else 0.3
        near = np.column_stack([rng.uniform(0, side, (dense, 2)), 0.05 * rng.standard_normal(dense)])
        g = np.arange(0, 8, 2.0) + 1.0  # 16 points 2 m apart, more than the largest radius
        gx, gy = np.meshgrid(g, g)
        sparse = np.column_stack([gx.ravel() + 11, gy.ravel(), np.zeros(gx.size)])
        xyz = np.vstack([near, sparse]) + [770_000.0, 6_277_000.0, 0.0]
        return PointCloud(xyz, np.full(len(xyz), 2), crs="EPSG:2154")

    pipeline = ls.Pipeline(scales=ls.radii(0.5, 0.6), progress=False)
    cm = changes(cloud(0), cloud(1), cell=10, min_points=10, pipeline=pipeline)
    t = cm.table
    assert t["points_a"][1] == 16 and t["defined_a"][1] == 0 and not t["valid"][1]
    assert t["valid"][0] and t["defined_a"][0] == 3000
    # 16 points in the sparse cell pass a count of all points, none has a defined saliency
    with pytest.raises(LidarSigError, match="10 points with defined saliency"):
        changes(cloud(0, 8), cloud(1, 8), cell=10, min_points=10, pipeline=pipeline)
