"""The change map (issues 13, 17): per-cell signatures and metrics on a grid of the CRS, the
defaults chosen from the densities, class maps, the outputs (GeoTIFF bands and metadata, JSON,
the map's decorations), series of epochs, the command line and its refusals. The level of
detection and the must-show figures on real data: tests/test_change_lod.py."""
import importlib.util
import json
import re
import subprocess
import sys
import warnings

import numpy as np
import pytest

import lidar_sig as ls
from command_line import run, run_process
from conftest import ROOT, SAMPLES, airborne_like
from lidar_sig.change_map import ChangeSeries, Grid, changes
from lidar_sig.method.cloud import PointCloud
from lidar_sig.base.errors import LidarSigError, LidarSigWarning
from lidar_sig.metrics import METRIC_KEYS
from robustness.helpers import assert_one_line_error, leftovers

sys.path.insert(0, str(ROOT / "benchmarks"))
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
        changes(a, a, cell=1, min_points=1000)


def test_unlabelled_epochs_rank_by_a_label_free_metric():
    a, b = small_cloud(0), small_cloud(1)
    a.labels = b.labels = None
    cm = changes(a, b, cell=10, min_points=100)
    assert cm.score == "fv" and np.isnan(cm.table["kl"]).all()
    valid = cm.table["valid"]
    assert np.array_equal(cm.table["score"][valid], cm.table["fv"][valid])
    assert not cm.levels["kl"].significant.any() and np.isnan(cm.levels["kl"].lod).all()


def test_one_unlabelled_epoch_is_said_not_shown_as_a_class_change():
    from lidar_sig.base.errors import LidarSigWarning

    a, b = small_cloud(0), small_cloud(1)
    b.labels = None
    with pytest.warns(LidarSigWarning, match="has no class labels.*geometry only"):
        cm = changes(a, b, cell=10, min_points=100)
    assert cm.score == "fv"


# -- the synthetic scene of data_samples -------------------------------------------------------

def coregistered_samples():
    """The two epochs of the sample scene (lidar_sig/data/_scene.py) without epoch 2's 20 degree
    rotation (the committed epoch2.laz is rotated about the scene centre to test rotation invariance, so its
    coordinates no longer describe the same ground as epoch 1's), and the changes' places."""
    from lidar_sig.data import _scene as ms

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
    # none significant at 16 m; ranked by lod_ratio, the building's cell is fifth after four
    # cells of cut trees (by z it was first), and no unchanged cell comes before them
    top = cm.ranked(5).tolist()
    building_cell = int(cm.grid.cell_of(building)[0])
    tree_cells = set(cm.grid.cell_of(trees).tolist())
    assert building_cell in top
    assert all(c in tree_cells or c == building_cell for c in top)
    assert cm.table["valid"].sum() >= 16


def sample_truth(grid):
    """Flat indices of the cells of ``grid`` that the sample scene's epoch 2 changed: those a cut
    tree's crown or the new building's footprint reaches."""
    from lidar_sig.data import _scene as ms

    scenes = ms.build_scenes()
    removed = [t for t in scenes[1].trees if t not in scenes[2].trees]
    changed = set()
    for c in range(grid.n_cells):
        x0, y0, x1, y1 = (float(v[0]) - o for v, o in zip(grid.bounds(np.array([c])), (ms.ORIGIN_X, ms.ORIGIN_Y) * 2))
        if any(np.hypot(max(x0 - t.x, 0, t.x - x1), max(y0 - t.y, 0, t.y - y1)) < t.radius for t in removed):
            changed.add(c)
        x, y = np.meshgrid(np.linspace(x0, x1, 9), np.linspace(y0, y1, 9))
        if (ms.NEW_BUILDING.distance(x, y) == 0).any():
            changed.add(c)
    return changed


def test_significant_cells_of_the_committed_sample_pair_are_cut_trees_and_the_new_building():
    # epoch2_aligned.laz is epoch 2 on epoch 1's ground (epoch2.laz is turned by 20 degrees to
    # show that whole-cloud signatures do not depend on orientation: docs/changes.md); 8 m cells
    # (the scene is 64 m wide: at 16 m most cells hold a cut tree, docs/changes.md)
    cm = changes(SAMPLES / "epoch1.laz", ALIGNED, cell=8)
    changed = sample_truth(cm.grid)
    significant = set(np.flatnonzero(cm.table["significant"]).tolist())
    assert cm.table["valid"].sum() >= 60 and len(significant) >= 5
    assert significant <= changed  # every cell called significant was edited
    assert set(cm.ranked(len(significant)).tolist()) == significant  # and they rank first
    assert set(cm.ranked(3).tolist()) <= changed


@pytest.fixture(scope="module")
def sample_run(tmp_path_factory):
    pytest.importorskip("rasterio", reason="rasterio not installed: pip install -e '.[geo]'")
    out = tmp_path_factory.mktemp("changes")
    # the command's end-to-end run, in a real process
    proc = run_process("changes", SAMPLES / "epoch1.laz", ALIGNED, "-o", out / "map.tif", "--cell", "8", "--png",
                       out / "map.png", "--report", out / "map.html", "--json", "--top", "100000")
    assert proc.returncode == 0, proc.stderr
    return out, json.loads(proc.stdout)


def test_geotiff_has_the_crs_transform_bands_metadata_and_no_data(sample_run):
    import rasterio

    out, info = sample_run
    with rasterio.open(out / "map.tif") as src:
        assert src.crs.to_epsg() == 2154
        a, b, c, d, e, f = tuple(src.transform)[:6]
        assert (a, b, d, e) == (8.0, 0.0, 0.0, -8.0)
        assert c % 8 == 0 and f % 8 == 0  # aligned to multiples of the cell size
        assert [a, b, c, d, e, f] == info["grid"]["transform"]
        assert src.nodata == -9999.0 and src.profile["compress"] == "deflate"
        names = src.descriptions
        assert names[0].startswith("score: delta_KL") and len(names) == 20
        assert names[1].startswith("lod: level of detection") and names[2].startswith("significant:")
        assert {n.split(":")[0] for n in names[3:11]} == {"d_BD-Img", "s_SSIM", "d_EMD-Info", "d_EMD-Img",
                                                          "delta_FV", "delta_KL", "L1", "delta_H"}
        assert names[16].startswith("coverage:") and names[11].startswith("height_lod:")
        assert names[17].startswith("lod_ratio:")  # added last: the seventeen before keep their numbers
        assert names[18].startswith("q:") and names[19].startswith("changed:")  # and after it, these two
        # short, as QGIS titles a band's legend "Band 18: " and its description; the full text its meaning
        assert max(len(n) for n in names) <= 60 - len("Band 20: ")
        assert "1 at the level, above 1 exactly where significant" in src.tags(18)["meaning"]
        changed, significant = src.read(20), src.read(3)
        assert np.array_equal(changed == 1, significant == 1)  # nothing appeared or vanished here
        height, height_lod, lod_ratio = src.read(11), src.read(12), src.read(18)
        tags = src.tags()
        score, lod, significant = src.read(1), src.read(2), src.read(3)
        points_a = src.read(names.index("points of epoch A") + 1)
    assert (tags["cell_m"], tags["cell_rule"], tags["min_points_rule"]) == ("8", "given", "auto")
    assert int(tags["min_points"]) == info["min_points"] and float(tags["confidence"]) == 0.95
    assert tags["score"] == "kl" and int(tags["significant"]) == info["grid"]["significant"]
    assert (score == -9999.0).any() and (score != -9999.0).sum() == info["grid"]["valid"]
    assert np.array_equal(score == -9999.0, significant == -9999.0)  # no data where not compared
    assert set(np.unique(significant[significant != -9999.0])) <= {0.0, 1.0}
    assert len(info["top"]) == info["grid"]["valid"]  # --top 100000 lists every compared cell
    for cell in info["top"]:  # the raster holds what the ranked list says, cell by cell
        r, k = cell["row"], cell["col"]
        assert score[r, k] == pytest.approx(cell["score"], rel=1e-6)
        assert lod[r, k] == pytest.approx(cell["lod"], rel=1e-6)
        assert height[r, k] == pytest.approx(cell["height"], rel=1e-6)
        assert height_lod[r, k] == pytest.approx(cell["height_lod"], rel=1e-6)
        assert significant[r, k] == float(cell["significant"])
        assert cell["significant"] == (cell["score"] > cell["lod"] or cell["height"] > cell["height_lod"])
        # how far the cell lies from its levels: above 1 exactly where it changed significantly
        assert lod_ratio[r, k] == pytest.approx(max(cell["score"] / cell["lod"], cell["height"] / cell["height_lod"]),
                                                rel=1e-6)
        assert (lod_ratio[r, k] > 1) == cell["significant"]
        assert isinstance(cell["significant"], bool)
        assert set(cell["significant_metrics"]) <= set(METRIC_KEYS) | {"height"}
        assert points_a[r, k] == cell["points_a"]
        x0, y0, x1, y1 = cell["bounds"]
        assert (x0, y1) == (c + k * 8, f - r * 8) and x1 - x0 == 8
        assert sum(na for na, _ in cell["classes"].values()) == cell["points_a"]
    # significant cells first, then by lod_ratio (the map's colour)
    flags = [cell["significant"] for cell in info["top"]]
    assert flags == sorted(flags, reverse=True) and sum(flags) == info["grid"]["significant"] >= 5
    for group in (True, False):
        ratio = [cell["lod_ratio"] for cell in info["top"] if cell["significant"] == group]
        assert ratio == sorted(ratio, reverse=True)
        assert all((r > 1) == group for r in ratio)
    assert info["cell_rule"] == "given" and info["min_points_rule"] == "auto" and info["confidence"] == 0.95
    assert set(info["levels"]) == set(METRIC_KEYS) | {"height"} and info["warnings"] == []


def test_gdalinfo_reads_the_geotiff(sample_run):
    out, info = sample_run
    text = subprocess.run(["gdalinfo", str(out / "map.tif")], capture_output=True, text=True, check=True).stdout
    assert "Lambert-93" in text and "NoData Value=-9999" in text and "Description = score: delta_KL" in text
    assert "Pixel Size = (8.000000000000000,-8.000000000000000)" in text and "min_points_rule=auto" in text


def test_png_map_and_html_report_are_written(sample_run):
    out, _ = sample_run
    assert (out / "map.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    html = (out / "map.html").read_text()
    assert html.count("data:image/png;base64,") == 1 + 2 * 5 and "Most changed cells" in html
    assert "changed significantly" in html and "Level of detection" in html
    assert "http" not in html.replace("http-equiv", "")  # self-contained


def test_cli_prints_the_ranked_cells_and_marks_the_significant_ones():
    proc = run("changes", SAMPLES / "epoch1.laz", ALIGNED, "--cell", "8", "--top", "6", "-q")
    assert proc.returncode == 0, proc.stderr
    lines = proc.stdout.splitlines()
    assert lines[0].startswith("9 x 9 cells of 8 m (given)") and "(auto)" in lines[0]
    compared = json.loads(run("changes", SAMPLES / "epoch1.laz", ALIGNED, "--cell", "8", "--json", "-q").stdout)
    assert lines[1].startswith(f"coverage: {compared['coverage']['cells']['compared']} cells compared")
    assert "delta_KL or delta_H" in lines[2] and "changed significantly" in lines[2]
    n = int(lines[2].split()[0])
    assert n >= 5
    assert lines[3].startswith(f"changed: {n} cells ({n} significant, 0 appeared and 0 vanished")
    ranks = [line.split()[0] for line in lines[5:]]
    assert ranks == [f"{k}*" if k <= n else str(k) for k in range(1, 7)]


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
    for value in ("0", "-25", "inf", "big"):
        proc = run("changes", SAMPLES / "epoch1.laz", SAMPLES / "epoch2.laz", "--cell", value,
                   "--png", tmp_path / "map.png")
        assert_one_line_error(proc, "cell size")
    proc = run("changes", SAMPLES / "epoch1.laz", SAMPLES / "epoch2.laz", "--class-map", "1,3,x=veg")
    assert_one_line_error(proc, "1,3,x=veg", "1,3,4,5=vegetation-or-other")
    proc = run("changes", SAMPLES / "epoch1.laz")
    assert_one_line_error(proc, "at least two epochs")
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
    assert len(order) == t["valid"].sum()
    significant = t["significant"][order]
    assert (np.diff(significant.astype(int)) <= 0).all()  # significant cells first
    for group in (significant, ~significant):  # then by lod_ratio, the quantity the cells are coloured by
        assert (np.diff(t["lod_ratio"][order][group]) <= 0).all()
    assert np.array_equal(t["significant"], (t["score"] > t["lod"]) | (t["height"] > t["height_lod"]))
    assert np.array_equal(t["lod_ratio"] > 1, t["significant"]) and np.isnan(t["lod_ratio"][~t["valid"]]).all()
    compared = t[t["valid"]]
    expected = np.maximum(compared["score"] / compared["lod"], compared["height"] / compared["height_lod"])
    np.testing.assert_allclose(compared["lod_ratio"], expected, rtol=1e-6)
    # each of the two tests at 97.5%, so that together they keep 95%
    assert np.array_equal(t["lod"], cm.levels["kl"].lod_at(0.975), equal_nan=True)
    assert (t["lod"][t["valid"]] > cm.levels["kl"].lod[t["valid"]]).all()
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


def test_withheld_and_noise_points_are_in_no_cell():
    # the same scene, once with withheld and noise points: by default the epochs are equal
    xyz, labels = airborne_like(6000, seed=3)
    rng = np.random.default_rng(9)
    noise = np.column_stack([rng.uniform(0, 40, (200, 2)), rng.uniform(30, 80, 200)])
    withheld = np.r_[np.zeros(6000 + 100, bool), np.ones(100, bool)]
    noisy = PointCloud(np.vstack([xyz, noise]), np.r_[labels, np.full(100, 18), np.full(100, 2)],
                       crs="EPSG:2154", withheld=withheld)
    clean = PointCloud(xyz, labels, crs="EPSG:2154")
    pipe = ls.Pipeline(progress=False)
    cmap = changes(clean, noisy, cell=20.0, min_points=200, pipeline=pipe)
    valid = cmap.table["valid"]
    assert valid.sum() >= 3 and np.array_equal(cmap.table["points_a"], cmap.table["points_b"])
    for key in ("bhattacharyya", "emd_info", "fv", "l1"):  # the same points, the same computation:
        assert np.all(cmap.table[key][valid] == 0.0), key   # exactly 0 on any CPU
    kept = changes(clean, noisy, cell=20.0, min_points=200, pipeline=ls.Pipeline(progress=False, keep_noise=True))
    assert kept.table["points_b"].sum() == len(noisy) and np.all(kept.table["l1"][kept.table["valid"]] > 0)


def test_withheld_and_noise_points_count_in_neither_the_densities_nor_the_grid(tmp_path):
    # the densities that choose the cell size and the fewest points, and the grid's extent,
    # counted every point: noise made the cells' minimum larger than for the same scene
    # without it, and withheld points 3 km away stretched the grid over them
    xyz, labels = airborne_like(6000, seed=3)
    rng = np.random.default_rng(9)
    far = np.column_stack([rng.uniform(3000, 3040, (100, 2)), np.zeros(100)])  # withheld, 3 km east
    noise = np.column_stack([rng.uniform(0, 40, (300, 2)), rng.uniform(30, 80, 300)])  # class 18

    def noisy(seed_offset):
        moved = xyz + [770_000.0 + seed_offset, 6_277_000.0, 0.0]
        extra = np.vstack([far, noise]) + [770_000.0, 6_277_000.0, 0.0]
        withheld = np.r_[np.zeros(6000, bool), np.ones(100, bool), np.zeros(300, bool)]
        return PointCloud(np.vstack([moved, extra]), np.r_[labels, np.full(100, 2), np.full(300, 18)],
                          crs="EPSG:2154", withheld=withheld)

    def clean(seed_offset):
        return PointCloud(xyz + [770_000.0 + seed_offset, 6_277_000.0, 0.0], labels, crs="EPSG:2154")

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", LidarSigWarning)  # few cells: the level of detection says so
        with_noise, without = changes(noisy(0.0), noisy(0.3)), changes(clean(0.0), clean(0.3))
    assert with_noise.density == pytest.approx(without.density, rel=1e-12)
    assert (with_noise.cell, with_noise.min_points) == (without.cell, without.min_points)
    assert with_noise.grid == without.grid
    for key in ("points_a", "points_b", "valid") + METRIC_KEYS:
        assert np.allclose(with_noise.table[key], without.table[key], rtol=0, atol=1e-12, equal_nan=True), key
    with_noise.save(tmp_path / "map.png")  # the top view is of the points used, inside the grid
    assert (tmp_path / "map.png").stat().st_size > 0


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
    # every point (no sample): the sparse cell's 16 points are all there
    cm = changes(cloud(0), cloud(1), cell=10, min_points=10, pipeline=pipeline, sample_density=None)
    t = cm.table
    assert t["points_a"][1] == 16 and t["defined_a"][1] == 0 and not t["valid"][1]
    assert t["valid"][0] and t["defined_a"][0] == 3000
    # 16 points in the sparse cell pass a count of all points, none has a defined saliency
    with pytest.raises(LidarSigError, match="10 points with defined saliency"):
        changes(cloud(0, 8), cloud(1, 8), cell=10, min_points=10, pipeline=pipeline, sample_density=None)


# -- defaults that fit the survey (issue 17) ----------------------------------------------------

def test_auto_cell_and_minimum_follow_the_documented_rule():
    from lidar_sig.change_map import auto_cell, auto_min_points, density

    # cell = max(25, sqrt(150 / d) rounded up to 5 m); min = max(30, 0.2 d cell^2) (docs/changes.md)
    for d, cell, least in ((50, 25, 6250), (28, 25, 3500), (0.3, 25, 38), (0.24, 25, 30), (0.2, 30, 36),
                           (0.1, 40, 32)):
        assert auto_cell(d) == cell and auto_min_points(d, auto_cell(d)) == least, d
    # density over the occupied 10 m pixels: a lake (no points) does not thin it
    rng = np.random.default_rng(0)
    land = rng.uniform(0, 100, (20_000, 2))
    land = land[land[:, 0] < 50]  # the east half is water
    assert density(land) == pytest.approx(len(land) / 5000.0, rel=0.02)
    feet = density(land / 0.3048, 0.3048)  # the same ground in feet: the same density per m²
    assert feet == pytest.approx(len(land) / 5000.0, rel=0.02)


def test_defaults_are_chosen_from_the_densities_and_recorded():
    a, b = small_cloud(0), small_cloud(1)
    cm = changes(a, b, cell=10)
    assert (cm.cell, cm.cell_rule, cm.min_points_rule) == (10.0, "given", "auto")
    d = min(cm.density)
    assert d == pytest.approx(len(a) / 1600.0, rel=0.05)  # 6,000 points over 40 x 40 m
    assert cm.min_points == max(30, round(0.2 * d * 100))
    info = cm.to_dict(0)
    assert info["min_points"] == cm.min_points and info["min_points_rule"] == "auto" and info["cell_rule"] == "given"
    with pytest.raises(LidarSigError, match="confidence"):
        changes(a, b, cell=10, confidence=1.5)
    with pytest.raises(LidarSigError, match="min_points"):
        changes(a, b, cell=10, min_points="many")


# -- class schemes (issue 17) -------------------------------------------------------------------

def test_class_maps_are_read_from_text_lists_dicts_and_files(tmp_path):
    from lidar_sig.method.class_maps import parse_class_map

    want = {"vegetation-or-other": [1, 3, 4, 5], "water": [9]}
    (tmp_path / "map.toml").write_text('vegetation-or-other = [5, 4, 3, 1]\nwater = 9\n')
    (tmp_path / "map.json").write_text(json.dumps(want))
    for given in ("1,3,4,5=vegetation-or-other; 9=water", ["1, 3,4,5 = vegetation-or-other", "9=water"],
                  {"vegetation-or-other": [1, 3, 4, 5], "water": [9]}, tmp_path / "map.toml", str(tmp_path / "map.json")):
        assert parse_class_map(given) == want, given


@pytest.mark.parametrize("given, said", [
    ("1,3,4,5", "codes, '=' and the merged class's name"),
    ("1,3,x=vegetation", "whole numbers separated by commas"),
    ("=vegetation", "whole numbers separated by commas"),
    ("1,3=", "codes, '=' and the merged class's name"),
    ("1,3=a;3,4=b", "code 3 is merged into both"),
    ({"a": [1, -2]}, "whole numbers from 0"),
    ({"a": "1,2"}, "whole numbers from 0"),
    (42, "a class map is text like"),
])
def test_a_bad_class_map_is_one_error_naming_the_value_and_the_fix(given, said):
    from lidar_sig.method.class_maps import parse_class_map

    with pytest.raises(LidarSigError, match=re.escape(said)) as err:
        parse_class_map(given)
    text = str(err.value)
    assert "\n" not in text and ("1,3,4,5=vegetation-or-other" in text or "class map" in text)
    if isinstance(given, str):
        assert given.split(";")[-1] in text or given in text


def test_class_map_files_that_cannot_be_read_are_named(tmp_path):
    from lidar_sig.method.class_maps import parse_class_map

    with pytest.raises(LidarSigError, match="not found"):
        parse_class_map(tmp_path / "none.toml")
    (tmp_path / "bad.json").write_text("{vegetation: [1, 3]")
    with pytest.raises(LidarSigError, match=r"bad\.json: cannot parse the class map"):
        parse_class_map(tmp_path / "bad.json")


def test_merged_classes_take_their_codes_from_either_scheme():
    from lidar_sig.method.class_maps import merge_classes
    from lidar_sig.method.classes import ASPRS

    table = merge_classes(ASPRS, "1,3,4,5=vegetation-or-other")
    names = table.class_names
    assert "vegetation-or-other" in names and not {"unclassified", "low vegetation", "high vegetation"} & set(names)
    index = table.index(np.array([1, 3, 4, 5, 2, 6, 64]))
    assert len(set(index[:4].tolist())) == 1 and index[4] != index[0] and index[5] != index[0]
    assert names[index[4]] == "ground" and names[index[5]] == "building" and names[index[6]] == "other"
    colour = table.colors[table.names.index("vegetation-or-other")]
    assert all(0 <= v <= 255 for v in colour)
    assert table.noise == ASPRS.noise == (7, 18)  # merging classes keeps the codes left out as noise
    with pytest.raises(LidarSigError, match="name the merged class differently"):
        merge_classes(ASPRS, "3=ground")  # "ground" still names class 2


def test_class_schemes_that_barely_overlap_are_said_and_ranked_without_labels():
    a, b = small_cloud(0), small_cloud(1)
    b.labels = np.where(b.labels == 5, 1, b.labels)  # B's scheme puts the trees in class 1
    with pytest.warns(LidarSigWarning, match="classified differently.*ranked by delta_FV"):
        cm = changes(a, b, cell=10, min_points=100)
    assert cm.score == "fv" and any("classified differently" in w for w in cm.warnings)
    with warnings.catch_warnings():
        warnings.simplefilter("error", LidarSigWarning)  # no class warning once merged
        merged = changes(a, b, cell=10, min_points=100, class_map="1,5=trees")
    assert merged.score == "kl" and "trees" in merged.class_table.names
    assert merged.table["kl"][merged.table["valid"]].max() < cm.table["kl"][cm.table["valid"]].max()


# -- more than two epochs (issue 17) ----------------------------------------------------------

def test_three_epochs_give_a_series_computed_once_per_epoch(tmp_path, monkeypatch):
    pytest.importorskip("rasterio", reason="rasterio not installed: pip install -e '.[geo]'")
    import rasterio

    calls = []
    original = ls.Pipeline.saliency
    monkeypatch.setattr(ls.Pipeline, "saliency", lambda self, cloud, **kw: calls.append(cloud) or original(self, cloud, **kw))
    a, b, c = small_cloud(0), small_cloud(1), small_cloud(2)
    series = changes(a, b, c, cell=10, min_points=100)
    assert isinstance(series, ChangeSeries) and len(series.maps) == 2 and len(calls) == 3
    assert series.maps[0].b is series.maps[1].a  # the middle epoch is shared, not computed twice
    when = series.when()  # the grid of cells, row 0 north
    assert when.shape == (series.grid.rows, series.grid.cols)
    valid = (series.maps[0].table["valid"] | series.maps[1].table["valid"]).reshape(when.shape)
    assert np.isnan(when[~valid]).all() and set(np.unique(when[valid])) <= {0.0, 1.0, 2.0}
    series.save(tmp_path / "series.tif")
    with rasterio.open(tmp_path / "series.tif") as src:
        names = src.descriptions
        assert len(names) == 2 * 20 + 1 and names[-1].startswith("when:")
        assert names[0].startswith("[1] score") and names[20].startswith("[2] score")
        assert src.tags(1)["meaning"].startswith("interval 1 (") and src.tags(21)["meaning"].startswith("interval 2 (")
        assert max(len(n) for n in names) <= 60 - len("Band 41: ")  # QGIS's legend title, within 60 characters
        assert np.array_equal(src.read(len(names)) == -9999.0, ~valid)
        assert src.tags()["epoch_3"]
    html = series.report().html()
    assert "Interval 1 (" in html and "Interval 2 (" in html and html.count("data:image/png;base64,") == 3
    info = series.to_dict(2)
    assert [i["interval"] for i in info["intervals"]] == [1, 2] and len(info["intervals"][0]["top"]) == 2
    assert sum(info["intervals"][0]["coverage"]["cells"].values()) == series.grid.n_cells
    assert sum(info["when"]["cells"].values()) == valid.sum()
    json.dumps(info)


def test_an_epoch_computed_once_serves_several_maps_with_its_method_only():
    from lidar_sig.change_map import compute_epoch

    a = compute_epoch(small_cloud(0))
    cm = changes(a, small_cloud(1), cell=10, min_points=100)
    assert cm.a is a
    with pytest.raises(LidarSigError, match="computed with another method"):
        changes(a, small_cloud(1), cell=10, min_points=100, pipeline=ls.Pipeline(strategy="optimal"))


def test_bad_values_given_to_the_change_map_s_functions_are_named():
    # a pipeline that is not one, a missing path and an unknown field raised AttributeError,
    # TypeError and ValueError
    from lidar_sig.change_map import compute_epoch

    with pytest.raises(LidarSigError, match="pipeline must be a lidar_sig.Pipeline, got 'asprs'"):
        compute_epoch(small_cloud(0), pipeline="asprs")
    cm = changes(small_cloud(0), small_cloud(1), cell=10, min_points=100)
    with pytest.raises(LidarSigError, match="takes a file path, got None"):
        cm.save(None)
    with pytest.raises(LidarSigError, match="no field 'nope'.*score"):
        cm.raster("nope")
    for cell in (10**9, -1, 1.5):  # a cell beyond the grid gave two empty signatures
        with pytest.raises(LidarSigError, match=f"no cell {cell!r} in a grid of {cm.grid.n_cells} cells"):
            cm.signatures(cell)
    with pytest.raises(LidarSigError, match="cannot read an epoch from an int"):  # was "a int"
        changes(5, small_cloud(1), cell=10)
    series = changes(small_cloud(0), small_cloud(1), small_cloud(2), cell=10, min_points=100)
    with pytest.raises(LidarSigError, match="takes a file path, got None"):
        series.save(None)


# -- the map reads like a map (issue 17) --------------------------------------------------------

def test_the_map_has_coordinates_a_north_arrow_and_a_legend_of_significance():
    from lidar_sig.reporting.change_scale import CHANGE_SCALE
    from lidar_sig.reporting.map_image import change_map_image, layout

    OUTLINE = CHANGE_SCALE.outline

    cm = changes(small_cloud(0), small_cloud(1), cell=10, min_points=100)
    cm.table["significant"][:] = False  # draw one cell as significant, the others not
    flat = int(cm.ranked(1)[0])
    cm.table["significant"][flat] = True
    image = change_map_image(cm)
    lay = layout(cm.grid)
    x, y, w, h = lay.arrow
    arrow = image[y + 2:y + h - 1, x + 2:x + w - 1]
    assert (arrow.max(axis=2) < 60).sum() > 30  # the arrow and its N, in ink
    # the significant cell is outlined in ink, a faded one is not
    r, k = divmod(flat, cm.grid.cols)
    side = lay.map_w // cm.grid.cols
    left = lay.map_x + k * side + 2
    assert (image[lay.map_y + r * side + side // 2, left] == OUTLINE).all()
    other = next(c for c in np.flatnonzero(cm.table["valid"]) if c != flat)
    r2, k2 = divmod(int(other), cm.grid.cols)
    assert not (image[lay.map_y + r2 * side + side // 2, lay.map_x + k2 * side + 2] == OUTLINE).all()
    # eastings below the map and the legend under it: ink in both bands
    ticks = image[lay.map_y + lay.map_h + 6:lay.legend_y, lay.map_x:lay.map_x + lay.map_w]
    assert (ticks.max(axis=2) < 60).any()
    assert image.shape[0] > lay.legend_y + 100 and (image[lay.legend_y:].max(axis=2) < 60).sum() > 500


def test_a_class_map_file_given_on_the_command_line_is_read(tmp_path):
    from lidar_sig.method.class_maps import parse_class_map

    (tmp_path / "veg.toml").write_text("vegetation = [3, 5]\n")
    assert parse_class_map([str(tmp_path / "veg.toml"), "9=water"]) == {"vegetation": [3, 5], "water": [9]}
    with pytest.raises(LidarSigError, match="'vegetation' is given twice"):
        parse_class_map([str(tmp_path / "veg.toml"), "4=vegetation"])


def test_a_series_geopackage_names_each_interval_s_layer_by_its_epochs():
    # issue 48: cells_1, cells_2 said nothing of the intervals
    from types import SimpleNamespace

    from lidar_sig.change_map._layers import interval_layer_names

    def series(*names):
        return SimpleNamespace(epochs=[SimpleNamespace(name=n) for n in names], maps=[None] * (len(names) - 1))

    assert interval_layer_names(series("/data/2019.laz", "/data/2021 survey.laz", "tiles/2023")) == \
        ["cells_2019_to_2021_survey", "cells_2021_survey_to_2023"]
    # the same pair twice: told apart by the interval's number
    assert interval_layer_names(series("a.laz", "b.laz", "a.laz", "b.laz")) == \
        ["cells_a_to_b_1", "cells_b_to_a", "cells_a_to_b_3"]
