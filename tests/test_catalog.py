"""Survey catalogues (docs/catalog.md): `lidar-sig catalog`, `similar` and `outliers`, on the six
IGN tiles plus three made ones (one tile rotated by 30 degrees about z, the same tile's 80%
random sample, another tile with every class code set to 1), and on small synthetic tiles."""
import json
import re
import shutil
import sqlite3
import subprocess
import sys
from pathlib import Path

import laspy
import numpy as np
import pyproj
import pytest

import lidar_sig as ls
from browser import Browser, missing
from conftest import IGN, NOISY, airborne_like, need_data, noisy_las
from lidar_sig.survey_catalog import build_catalog
from lidar_sig.survey_catalog._embedding import classical_mds
from lidar_sig.survey_catalog._footprint import convex_hull, neighbours, polygon_area, polygon_distance
from lidar_sig.survey_catalog._outlier_scores import robust_z
from lidar_sig.survey_catalog._tile import tile_task
from lidar_sig.io.geopackage import APPLICATION_ID
from lidar_sig.tiling.backends import executor

ORIGINAL = "test_data_77055_627755_LA93_IGN69.laz"
OTHER = "test_data_77060_627760_LA93_IGN69.laz"


def run(*args, cwd=None):
    return subprocess.run([sys.executable, "-m", "lidar_sig", *map(str, args)], capture_output=True, text=True,
                          cwd=cwd)


def make_tiles(folder):
    """The three made tiles, written as LAZ in ``folder`` (the IGN tiles are read where they are)."""
    src = IGN / ORIGINAL
    las = laspy.read(src)
    x, y = np.asarray(las.x), np.asarray(las.y)
    cx, cy = (x.min() + x.max()) / 2, (y.min() + y.max()) / 2
    t = np.radians(30.0)
    rotated = laspy.read(src)  # about the tile's centre, z unchanged
    rotated.x = cx + np.cos(t) * (x - cx) - np.sin(t) * (y - cy)
    rotated.y = cy + np.sin(t) * (x - cx) + np.cos(t) * (y - cy)
    rotated.write(folder / "rotated_30.laz")
    keep = np.random.default_rng(0).random(len(las.points)) < 0.8
    sample = laspy.LasData(las.header)
    sample.points = las.points[keep]
    sample.write(folder / "sample_80.laz")
    other = laspy.read(IGN / OTHER)
    other.classification[:] = 1
    other.write(folder / "all_class_1.laz")
    return folder


@pytest.fixture(scope="module")
def nine(tmp_path_factory):
    """The catalogue of the six IGN tiles and the three made ones (computed once for the module)."""
    need_data(IGN)
    top = tmp_path_factory.mktemp("nine")
    (top / "made").mkdir()
    made = make_tiles(top / "made")
    run_ = build_catalog([IGN, made], top / "nine.h5")
    assert run_.complete and len(run_.added) == 9, run_.missing
    return ls.Catalog(top / "nine.h5")


def synthetic_tile(path, seed, offset, *, classes=None):
    """A small airborne-like LAZ tile (3,000 points) in Lambert-93 at ``offset`` (x, y)."""
    xyz, labels = airborne_like(3000, seed=seed)
    xyz = xyz + [700000 + offset[0], 6600000 + offset[1], 50]
    header = laspy.LasHeader(point_format=6, version="1.4")
    header.scales, header.offsets = [0.01] * 3, np.floor(xyz.min(axis=0))
    header.add_crs(pyproj.CRS.from_epsg(2154))
    las = laspy.LasData(header)
    las.x, las.y, las.z = xyz.T
    las.classification = labels if classes is None else np.full(len(xyz), classes)
    las.write(path)
    return path


# -- the two questions on the nine tiles ----------------------------------------------------

def test_similar_lists_the_tile_s_rotated_copy_and_its_sample_first_and_leaves_the_tile_out(nine):
    found = nine.similar(ORIGINAL, top=9)
    names = found.names()
    assert ORIGINAL not in names and len(names) == 8  # the query is no answer (issue 32)
    assert set(names[:2]) == {"rotated_30.laz", "sample_80.laz"}
    distances = [r["distance"] for r in found.results]
    assert distances == sorted(distances)
    assert found.shortlist["certain"] and found.query["tile"]


def test_outliers_rank_the_tile_without_classes_first(nine):
    found = nine.outliers()
    first = found.results[0]
    assert first["name"] == "all_class_1.laz"
    assert first["score"] > found.results[1]["score"]
    # what makes the difference: its points are all "unclassified", its neighbours' a few percent
    assert first["classes"][0]["class"] == "unclassified" and first["classes"][0]["share"] == pytest.approx(100.0)
    assert first["classes"][0]["difference"] > 80.0
    assert len(first["neighbours"]) >= 2  # adjacent tiles of the block, found from the footprints


def test_similar_gives_compare_s_values_for_every_tile(nine):
    # each tile's signature is its own (saliency on the tile alone), and similar's metrics are
    # compare's between the signatures, whatever the shortlist
    query = nine.signature(ORIGINAL)
    own = ls.Pipeline(progress=False).run(IGN / ORIGINAL).signature
    assert np.array_equal(query.counts, own.counts) and np.array_equal(query.class_totals, own.class_totals)
    found = nine.similar(ORIGINAL, top=9, shortlist=9)
    for r in found.results:
        expected = ls.compare(query, nine.signature(r["name"]))
        for key, value in expected.items():
            assert r[key] == pytest.approx(value, rel=1e-9, abs=1e-9), (r["name"], key)


def test_screening_metrics_of_all_pairs_are_the_metrics_own(nine):
    from lidar_sig import metrics

    f = nine.features
    funcs = {"bhattacharyya": lambda i, j: metrics.bhattacharyya(f.color[i], f.color[j]),
             "emd_info": lambda i, j: metrics.emd_info(f.egeom[i], f.egeom[j]),
             "fv": lambda i, j: float(np.linalg.norm(f.fv[i] - f.fv[j])),
             "kl": lambda i, j: metrics.symmetric_kl(f.totals[i], f.totals[j]),
             "l1": lambda i, j: metrics.l1_distance(f.totals[i], f.totals[j])}
    for key, pair in funcs.items():
        matrix = nine.distances(key)
        for i in range(len(nine)):
            for j in range(len(nine)):
                if i != j:
                    assert matrix.values[i, j] == pytest.approx(pair(i, j), rel=1e-9, abs=1e-12), (key, i, j)


def test_the_shortlist_does_not_change_the_top_three(nine):
    # every tile as the query: the top 3 from a shortlist of 4 (of 9) are the top 3 from the
    # full metrics of every tile
    certain = 0
    for name in nine.names:
        short = nine.similar(name, top=3, shortlist=4)
        full = nine.similar(name, top=3, shortlist=len(nine))
        assert short.names() == full.names(), name
        certain += short.shortlist["certain"]
    assert certain >= 1  # the bound proves it for some queries without computing the others


def test_a_query_cloud_is_computed_with_the_catalogue_s_method(nine, tmp_path):
    cloud = ls.read(IGN / ORIGINAL)
    cloud.path = None  # not recognised as the catalogue's tile by its path
    found = nine.similar(cloud, top=2)
    assert found.query["kind"] == "cloud" and not found.query["tile"]
    assert found.names()[0] == ORIGINAL and found.results[0]["distance"] == pytest.approx(0.0, abs=1e-6)
    other = ls.Pipeline(scales=ls.knn(10, 20), progress=False)
    archive = tmp_path / "other.h5"
    other.run(IGN / ORIGINAL).write(archive)
    with pytest.raises(ls.LidarSigError, match="another method"):
        nine.similar(archive)
    with pytest.raises(ls.LidarSigError, match="neither a tile"):
        nine.similar("no_such_tile.laz")


# -- growing, resuming ------------------------------------------------------------------------

def names(paths):
    return [Path(p).name for p in paths]


def test_a_catalogue_grown_by_one_tile_computes_only_that_tile(tmp_path):
    tiles = tmp_path / "tiles"
    tiles.mkdir()
    synthetic_tile(tiles / "a.laz", 0, (0, 0))
    synthetic_tile(tiles / "b.laz", 1, (40, 0))
    out = tmp_path / "c.h5"
    first = build_catalog([tiles], out)
    assert sorted(names(first.added)) == ["a.laz", "b.laz"]
    before = ls.Catalog(out)
    synthetic_tile(tiles / "c.laz", 2, (0, 40))
    grown = build_catalog([tiles], out)
    assert names(grown.added) == ["c.laz"] and len(grown.unchanged) == 2
    after = ls.Catalog(out)
    assert after.names == ["a.laz", "b.laz", "c.laz"]
    for name in ("a.laz", "b.laz"):  # kept as they were, not recomputed
        i, j = before.index(name), after.index(name)
        assert before.columns["meta"][i] == after.columns["meta"][j]
        assert np.array_equal(before.signature(name).counts, after.signature(name).counts)
    synthetic_tile(tiles / "b.laz", 5, (40, 0))  # a changed file is computed again
    changed = build_catalog([tiles], out)
    assert names(changed.updated) == ["b.laz"] and len(changed.unchanged) == 2
    with pytest.raises(ls.LidarSigError, match="another method"):
        build_catalog([tiles], out, ls.Pipeline(scales=ls.knn(10, 20)))
    with pytest.raises(ls.LidarSigError, match="pipeline must be a lidar_sig.Pipeline"):  # was AttributeError
        ls.Catalog.build([tiles], out, "asprs")
    assert not (tmp_path / "c.h5.work").exists()  # removed after complete runs


def test_withheld_and_noise_points_are_left_out_of_every_tile_and_query_alike(tmp_path):
    # the catalogue's class table was written without its noise codes: read back, it kept class
    # 7 and 18 points that the tiles had left out, so that a copy of a tile queried as a cloud
    # was not at 0 from it, its archive was refused ("another frame or class table (512 px,
    # 'asprs') than the catalogue (512 px, 'asprs')"), a tile added later kept its noise and a
    # default Pipeline could not grow the catalogue
    import h5py

    tiles = tmp_path / "tiles"
    tiles.mkdir()
    for k in range(3):
        noisy_las(tiles / f"t{k}.las", n=3000, seed=20 + k)
    out = tmp_path / "c.h5"
    assert build_catalog([tiles], out).complete
    cat = ls.Catalog(out)
    assert cat.classes == ls.ASPRS and cat.classes.noise == (7, 18)
    own = ls.Pipeline(progress=False).run(tiles / "t0.las")
    assert own.metadata["n_excluded"] == sum(NOISY.values())
    tile = cat.signature("t0.las")
    assert np.array_equal(tile.counts, own.signature.counts)
    assert np.array_equal(tile.class_totals, own.signature.class_totals) and tile.class_totals[[7, 18]].sum() == 0
    copy = tmp_path / "copy.las"
    shutil.copy(tiles / "t0.las", copy)
    archive = tmp_path / "t0.h5"
    own.write(archive)
    for query in (copy, archive):
        found = cat.similar(query, top=1)
        assert found.names() == ["t0.las"], query
        assert found.results[0]["distance"] == pytest.approx(0.0, abs=1e-9), (query, found.results[0])
    # queries that are no tile, cloud or archive are named (an empty one was read as the folder
    # '.'; a row out of range was 'cannot query a catalogue with a int')
    with pytest.raises(ls.LidarSigError, match="the query is empty"):
        cat.similar("")
    with pytest.raises(ls.LidarSigError, match=r"no tile at row 3 .*3 tiles \(rows 0 to 2\)"):
        cat.similar(3)
    paper = tmp_path / "paper.h5"
    ls.Pipeline(classes="paper", progress=False).run(copy).write(paper)
    with pytest.raises(ls.LidarSigError, match="'paper' with noise codes 7, 18.*'asprs' with noise codes 7, 18"):
        cat.similar(paper)
    noisy_las(tiles / "t3.las", n=3000, seed=23)
    grown = build_catalog([tiles], out, ls.Pipeline(progress=False))  # the same method: it grows
    assert names(grown.added) == ["t3.las"]
    added = ls.Catalog(out).signature("t3.las")
    assert np.array_equal(added.class_totals, ls.Pipeline(progress=False).run(tiles / "t3.las").signature.class_totals)
    assert added.class_totals[[7, 18]].sum() == 0
    with h5py.File(out, "r+") as f:  # as catalogues made before the noise codes were recorded
        table = json.loads(f.attrs["classes"])
        del table["noise"]
        f.attrs["classes"] = json.dumps(table)
    assert ls.Catalog(out).classes == ls.ASPRS


def test_a_failed_tile_is_named_and_resume_reuses_finished_tiles(tmp_path):
    tiles = tmp_path / "tiles"
    tiles.mkdir()
    synthetic_tile(tiles / "a.laz", 0, (0, 0))
    (tiles / "broken.laz").write_bytes(b"not a LAS file")
    out = tmp_path / "c.h5"
    failed = build_catalog([tiles], out)
    assert not failed.complete and names(failed.failed) == ["broken.laz"]
    assert ls.Catalog(out).names == ["a.laz"]  # the good tile is in the catalogue
    assert (tmp_path / "c.h5.work").is_dir()  # work kept
    # an interrupted run: a tile finished in the work folder, no catalogue written
    (tiles / "broken.laz").unlink()
    synthetic_tile(tiles / "b.laz", 1, (40, 0))
    work = tmp_path / "c.h5.work"
    tile_task(str(work), str((tiles / "b.laz").resolve()), ls.Pipeline(progress=False))
    resumed = build_catalog([tiles], out, resume=True)
    assert names(resumed.resumed) == ["b.laz"] and resumed.complete
    assert ls.Catalog(out).names == ["a.laz", "b.laz"]


def test_a_dask_cluster_makes_the_same_catalogue(tmp_path):
    distributed = pytest.importorskip("distributed", reason="the dask extra is not installed")
    tiles = tmp_path / "tiles"
    tiles.mkdir()
    synthetic_tile(tiles / "a.laz", 0, (0, 0))
    synthetic_tile(tiles / "b.laz", 1, (40, 0))
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster:
        backend = executor(scheduler=cluster.scheduler_address)
        try:
            on_dask = build_catalog([tiles], tmp_path / "dask.h5", backend=backend)
        finally:
            backend.close()
    assert on_dask.complete and on_dask.execution.startswith("Dask")
    build_catalog([tiles], tmp_path / "here.h5")
    a, b = ls.Catalog(tmp_path / "dask.h5"), ls.Catalog(tmp_path / "here.h5")
    for name in ("a.laz", "b.laz"):  # every count and vector as in this process
        assert np.array_equal(a.signature(name).counts, b.signature(name).counts)
    assert np.array_equal(a.features.fv, b.features.fv) and np.array_equal(a.features.color, b.features.color)


def test_a_tile_larger_than_a_block_goes_through_the_tiled_runner(tmp_path, monkeypatch):
    import lidar_sig.survey_catalog._tile as tile

    path = synthetic_tile(tmp_path / "a.laz", 0, (0, 0))
    monkeypatch.setattr(tile, "BLOCK_POINTS", 1000)
    big = build_catalog([path], tmp_path / "tiled.h5")
    monkeypatch.setattr(tile, "BLOCK_POINTS", 10**9)
    block = build_catalog([path], tmp_path / "block.h5")
    assert big.complete and block.complete
    a, b = ls.Catalog(tmp_path / "tiled.h5"), ls.Catalog(tmp_path / "block.h5")
    assert json.loads(a.columns["meta"][0])["tiled"] and not json.loads(b.columns["meta"][0])["tiled"]
    assert np.array_equal(a.signature(0).counts, b.signature(0).counts)
    assert np.allclose(a.columns["hull"][0], b.columns["hull"][0])


# -- outputs: GeoPackage, report, command line ------------------------------------------------

def test_the_geopackage_opens_with_gdal_with_one_polygon_per_tile(nine, tmp_path):
    found = nine.outliers()
    gpkg = tmp_path / "tiles.gpkg"
    found.write_geopackage(gpkg)
    with sqlite3.connect(gpkg) as con:
        assert con.execute("PRAGMA application_id").fetchone()[0] == APPLICATION_ID
    if shutil.which("ogrinfo") is None:
        pytest.skip("ogrinfo (GDAL, Debian package gdal-bin) is not installed: the file's SQLite tables were checked")
    summary = subprocess.run(["ogrinfo", "-al", "-so", str(gpkg)], capture_output=True, text=True)
    assert summary.returncode == 0, summary.stderr
    assert "Geometry: Polygon" in summary.stdout and "Feature Count: 9" in summary.stdout
    assert 'ID["EPSG",2154]' in summary.stdout
    for field in ("name", "score", "z_neighbours", "z_survey", "bhattacharyya", "emd_info", "fv", "kl", "l1",
                  "classes"):
        assert re.search(rf"^{field}: ", summary.stdout, re.M), field
    features = subprocess.run(["ogrinfo", "-al", str(gpkg)], capture_output=True, text=True).stdout
    assert features.count("POLYGON ((") == 9
    scores = dict(zip(re.findall(r"name \(String\) = (\S+)", features),
                      map(float, re.findall(r"score \(Real\) = (\S+)", features))))
    for r in found.results:
        assert scores[r["name"]] == pytest.approx(r["score"], rel=1e-9)


def test_a_geopackage_has_a_layer_per_crs(tmp_path):
    from lidar_sig.io.geopackage import write_geopackage

    square = np.array([[0, 0], [10, 0], [10, 10], [0, 10]], float)
    wkt = pyproj.CRS.from_epsg(2154).to_wkt()
    write_geopackage(tmp_path / "two.gpkg", {wkt: [(square, {"name": "a", "score": 1.5})],
                                             None: [(square + 20, {"name": "b", "score": -0.5})]})
    with sqlite3.connect(tmp_path / "two.gpkg") as con:
        layers = dict(con.execute("SELECT table_name, srs_id FROM gpkg_geometry_columns").fetchall())
    assert layers == {"tiles_2154": 2154, "tiles_no_crs": -1}
    if shutil.which("ogrinfo") is None:
        pytest.skip("ogrinfo (GDAL, Debian package gdal-bin) is not installed: the SQLite tables were checked")
    done = subprocess.run(["ogrinfo", "-al", "-so", str(tmp_path / "two.gpkg")], capture_output=True, text=True)
    assert done.returncode == 0 and done.stdout.count("Feature Count: 1") == 2, done.stdout + done.stderr


def test_the_outliers_report_opens_in_headless_chromium(nine, tmp_path):
    found = nine.outliers()
    report = found.report()
    report.save(tmp_path / "outliers.html")
    html = (tmp_path / "outliers.html").read_text(encoding="utf-8")
    assert not re.search(r'(src|href)="(?!data:|#)', html) and "<script" not in html.lower()
    for title in ("Tiles by score", "Map", "Top outliers beside their neighbours", "Tiles by likeness"):
        assert f"<h2>{title}</h2>" in html
    why = missing()
    if why:
        pytest.skip(f"no headless browser: {why}")
    with Browser(width=1280) as browser:
        browser.open(tmp_path / "outliers.html")
        images = browser.images()
        rows = browser.table("table.outliers")
        console = browser.console()
    assert len(images) == len(report.figures)
    assert all(width > 0 and height > 0 for _, width, height in images), images
    assert rows[0][1] == "all_class_1.laz" and "unclassified" in rows[0][-1]
    assert [c for c in console if c[0] in ("SEVERE", "ERROR", "WARNING")] == []


def test_the_commands_print_json_best_first_and_write_their_outputs(nine, tmp_path):
    done = run("similar", ORIGINAL, nine.path, "--top", "3", "--json")
    assert done.returncode == 0, done.stderr
    out = json.loads(done.stdout)
    assert {r["name"] for r in out["results"]} == {"rotated_30.laz", "sample_80.laz", OTHER}  # the query left out
    assert all({"path", "distance", "ssim", "l1"} <= set(r) for r in out["results"])
    done = run("outliers", nine.path, "--json", "-o", tmp_path / "t.gpkg")  # the report: tested above
    assert done.returncode == 0, done.stderr
    out = json.loads(done.stdout)
    scores = [r["score"] for r in out["results"]]
    assert out["results"][0]["name"] == "all_class_1.laz" and scores == sorted(scores, reverse=True)
    assert (tmp_path / "t.gpkg").is_file()
    bad = run("similar", "no_such_tile.laz", nine.path)
    assert bad.returncode == 2 and len(bad.stderr.strip().splitlines()) == 1 and "neither a tile" in bad.stderr


# -- pieces -----------------------------------------------------------------------------------

def test_footprints_hulls_distances_and_neighbours():
    square = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], float)
    rng = np.random.default_rng(0)
    hull = convex_hull(np.vstack([square, rng.random((200, 2))]))
    assert polygon_area(hull) == pytest.approx(1.0)
    assert polygon_distance(square, square + [3, 0]) == pytest.approx(2.0)
    assert polygon_distance(square, square + [1, 1]) == 0.0  # touching at a corner
    assert polygon_distance(square, square + [2, 2]) == pytest.approx(np.sqrt(2))  # corner to corner
    assert polygon_distance(square, square + [0.5, 0.2]) == 0.0
    # a 3 x 3 grid of unit tiles: the centre touches all eight others, a corner three
    grid = [square + [i, j] for i in range(3) for j in range(3)]
    bounds = np.array([[*g.min(axis=0), *g.max(axis=0)] for g in grid])
    found = neighbours(grid, bounds, 0.25)
    assert len(found[4]) == 8 and len(found[0]) == 3
    assert len(neighbours(grid, bounds, 1.0)[0]) == 7  # a tile side away: all but the far corner (sqrt 2)


def test_robust_z_and_classical_mds():
    z = robust_z([1.0, 2.0, 3.0, 4.0, 100.0])
    assert z[2] == 0.0 and z[-1] > 10 * z[3] > 0
    assert np.isnan(robust_z([1.0, np.nan, 2.0])[1])
    points = np.random.default_rng(1).random((7, 2)) * 10
    d = np.sqrt(((points[:, None] - points[None]) ** 2).sum(axis=2))
    xy = classical_mds(d)
    assert np.allclose(np.sqrt(((xy[:, None] - xy[None]) ** 2).sum(axis=2)), d)
