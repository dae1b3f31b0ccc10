"""Outputs that open right in a GIS (issue 32): the change map as a Cloud-Optimized GeoTIFF with
its QGIS style beside it, the cells and the catalogue's tiles as GeoPackages with a spatial
index and a stored default style, the later epoch's points with their cell's change as extra
dimensions that laspy describes and CloudCompare names. Checked with GDAL's own tools (Debian's
gdal-bin and python3-gdal: validate_cloud_optimized_geotiff.py, validate_gpkg.py, ogrinfo);
QGIS itself opens them in tests/test_qgis.py."""
import json
import shutil
import sqlite3
import subprocess
import xml.etree.ElementTree as ET

import numpy as np
import pytest

from command_line import run
from conftest import SAMPLES
from robustness.helpers import assert_one_line_error, leftovers

ALIGNED = SAMPLES / "epoch2_aligned.laz"
SYSTEM_PYTHON = "/usr/bin/python3"  # Debian's, where python3-gdal puts GDAL's Python tools


def gdal_tool(module):
    """The command running one of GDAL's Python samples (python3-gdal), or a skip saying why."""
    if shutil.which(SYSTEM_PYTHON) is None:
        pytest.skip(f"{SYSTEM_PYTHON} is not here to run GDAL's {module}")
    probe = subprocess.run([SYSTEM_PYTHON, "-c", f"import osgeo_utils.samples.{module}"], capture_output=True)
    if probe.returncode != 0:
        pytest.skip(f"GDAL's {module}.py is not installed (Debian: apt-get install python3-gdal)")
    return [SYSTEM_PYTHON, "-m", f"osgeo_utils.samples.{module}"]


def ogrinfo(*args):
    if shutil.which("ogrinfo") is None:
        pytest.skip("ogrinfo is not installed (Debian: apt-get install gdal-bin)")
    done = subprocess.run(["ogrinfo", "-ro", *map(str, args)], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    return done.stdout


@pytest.fixture(scope="module")
def outputs(tmp_path_factory):
    """The sample pair with 8 m cells (15 significant cells), every GIS output written by the
    command, and its JSON of every compared cell."""
    pytest.importorskip("rasterio", reason="rasterio not installed: pip install -e '.[geo]'")
    out = tmp_path_factory.mktemp("gis")
    done = run("changes", SAMPLES / "epoch1.laz", ALIGNED, "--cell", "8", "-o", out / "map.tif", "--cells",
               out / "cells.gpkg", "--points", out / "later.laz", "--json", "--top", "100000", cwd=out)
    assert done.returncode == 0, done.stderr
    return out, json.loads(done.stdout)


# -- the change map's GeoTIFF ------------------------------------------------------------------

def test_the_change_map_is_a_valid_cloud_optimized_geotiff(outputs):
    out, _ = outputs
    done = subprocess.run([*gdal_tool("validate_cloud_optimized_geotiff"), str(out / "map.tif")],
                          capture_output=True, text=True)
    assert done.returncode == 0 and "is a valid cloud optimized GeoTIFF" in done.stdout, done.stdout + done.stderr


def test_a_map_larger_than_a_tile_gets_overviews_and_stays_valid(tmp_path):
    rasterio = pytest.importorskip("rasterio", reason="rasterio not installed: pip install -e '.[geo]'")
    from lidar_sig.io.geotiff import NODATA, write_geotiff

    rng = np.random.default_rng(0)
    bands = [rng.random((700, 600)), rng.random((700, 600))]
    bands[0][:40, :40] = np.nan
    write_geotiff(tmp_path / "big.tif", bands, ["a", "b"], (25.0, 0.0, 770000.0, 0.0, -25.0, 6280000.0),
                  "EPSG:2154", tags={"cell_m": "25"})
    with rasterio.open(tmp_path / "big.tif") as src:
        assert src.overviews(1) == [2, 4] and src.block_shapes[0] == (256, 256)  # down to one 256 px tile
        assert src.descriptions == ("a", "b") and src.tags()["cell_m"] == "25" and src.nodata == NODATA
        np.testing.assert_array_equal(src.read(2), bands[1].astype(np.float32))
        assert (src.read(1)[:40, :40] == NODATA).all()
    done = subprocess.run([*gdal_tool("validate_cloud_optimized_geotiff"), str(tmp_path / "big.tif")],
                          capture_output=True, text=True)
    assert done.returncode == 0 and "is a valid cloud optimized GeoTIFF" in done.stdout, done.stdout
    assert leftovers(tmp_path) == []


def ramp_of(qml_path):
    """(band, [(upper bound, colour, label)]) of a change map's style: the band it draws and its
    classes, as QGIS reads the QML."""
    renderer = ET.parse(qml_path).getroot().find("pipe/rasterrenderer")
    assert renderer.get("type") == "singlebandpseudocolor"
    shader = renderer.find("rastershader/colorrampshader")
    assert shader.get("colorRampType") == "DISCRETE"  # classes: a value takes the first bound it does not exceed
    return int(renderer.get("band")), [(float(i.get("value")), i.get("color"), i.get("label"))
                                       for i in shader.findall("item")]


def ramp_of_text(qml):
    """:func:`ramp_of`'s classes of a style given as text."""
    shader = ET.fromstring(qml).find("pipe/rasterrenderer/rastershader/colorrampshader")
    return [(float(i.get("value")), i.get("color"), i.get("label")) for i in shader.findall("item")]


def drawn(ramp, value):
    """The colour QGIS gives ``value`` in a discrete ramp."""
    return next(colour for bound, colour, _ in ramp if value <= bound)


@pytest.fixture(scope="module")
def three_maps(outputs, tmp_path_factory):
    """The sample pair at 8 m cells (the command's), the same pair at 16 m cells (another
    highest score) and epoch 1 against itself (no change: every score 0), each as its GeoTIFF,
    its style and its compared cells' (lod_ratio, significant)."""
    import rasterio

    out = tmp_path_factory.mktemp("three")
    maps = {"8 m": out / "m8.tif", "16 m": out / "m16.tif", "no change": out / "same.tif"}
    done = [run("changes", SAMPLES / "epoch1.laz", ALIGNED, "--cell", "16", "-o", maps["16 m"], "-q"),
            run("changes", SAMPLES / "epoch1.laz", SAMPLES / "epoch1.laz", "--cell", "8", "-o", maps["no change"],
                "-q")]
    assert all(d.returncode == 0 for d in done), [d.stderr for d in done]
    shutil.copy(outputs[0] / "map.tif", maps["8 m"])
    shutil.copy(outputs[0] / "map.qml", out / "m8.qml")
    found = {}
    for name, path in maps.items():
        with rasterio.open(path) as src:
            band = src.descriptions.index(next(d for d in src.descriptions if d.startswith("lod_ratio:"))) + 1
            ratio, score, significant = src.read(band), src.read(1), src.read(3)
        valid = significant != -9999.0
        found[name] = {"qml": path.with_suffix(".qml"), "band": band, "ratio": ratio[valid],
                       "significant": significant[valid] == 1, "top": float(score[valid].max())}
    return found


def test_the_map_s_colours_say_how_far_a_cell_is_from_its_level_the_same_on_every_map(three_maps):
    maps = three_maps
    assert maps["8 m"]["top"] != pytest.approx(maps["16 m"]["top"], rel=0.05) and maps["no change"]["top"] == 0
    ramps = {name: ramp_of(m["qml"]) for name, m in maps.items()}
    from lidar_sig.change_map._layers import level_style

    full = ramp_of_text(level_style(maps["8 m"]["band"]))  # the fixed scale, every class
    for name, (band, ramp) in ramps.items():
        assert band == maps[name]["band"]  # the style draws lod_ratio, not the score
        assert set(ramp) <= set(full)  # classes of the one scale: the same bounds, colours and labels
        # its legend lists the classes that hold a cell of the map, and each cell takes its colour
        # on the whole scale, whichever classes another map lists
        assert {drawn(full, float(v)) for v in maps[name]["ratio"]} == {colour for _, colour, _ in ramp}, name
        assert all(drawn(ramp, float(v)) == drawn(full, float(v)) for v in maps[name]["ratio"]), name
    ramp = full
    bounds = [bound for bound, _, _ in ramp]
    assert bounds == sorted(bounds) and 1.0 in bounds and bounds[-1] == float("inf")
    assert not any("highest" in label for _, _, label in ramp)  # nothing drawn from the map's own maximum
    below = {colour for bound, colour, _ in ramp if bound <= 1.0}
    above = {colour for bound, colour, _ in ramp if bound > 1.0}
    assert not below & above  # the level of detection is a break in the colours
    assert all(c[1:3] == c[3:5] == c[5:7] for c in below)  # not significant: greys
    assert all(int(c[1:3], 16) > int(c[5:7], 16) for c in above)  # significant: warm, yellow to dark red
    # each compared cell: a significant cell is drawn above the break, any other below it
    for name, m in maps.items():
        colours = [drawn(ramp, float(v)) for v in m["ratio"]]
        assert [c in above for c in colours] == m["significant"].tolist(), name
    assert maps["8 m"]["significant"].sum() >= 5 and not maps["no change"]["significant"].any()
    assert {drawn(ramp, float(v)) for v in maps["no change"]["ratio"]} <= below  # no warm colour without change


def test_gdal_reads_a_map_without_a_significant_cell_without_an_error(three_maps, tmp_path):
    if shutil.which("gdalinfo") is None:
        pytest.skip("gdalinfo is not installed (Debian: apt-get install gdal-bin)")
    copy = tmp_path / "same.tif"  # gdalinfo -stats writes its .aux.xml beside the file
    shutil.copy(three_maps["no change"]["qml"].with_suffix(".tif"), copy)
    done = subprocess.run(["gdalinfo", "-stats", str(copy)], capture_output=True, text=True)
    assert done.returncode == 0 and "ERROR" not in done.stdout + done.stderr, done.stderr
    assert "STATISTICS_MAXIMUM=0" in done.stdout  # band 3, significant: 0 in every compared cell


def test_a_style_file_in_the_way_is_refused_before_any_work(tmp_path):
    (tmp_path / "map.qml").write_text("mine")
    done = run("changes", SAMPLES / "epoch1.laz", ALIGNED, "-o", tmp_path / "map.tif", cwd=tmp_path)
    assert_one_line_error(done, "map.qml", "--overwrite")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["map.qml"] and (tmp_path / "map.qml").read_text() == "mine"


# -- GeoPackages: the cells and the catalogue's tiles --------------------------------------------

def check_geopackage(path, layer, features):
    """GDAL's validator passes; the layer has a spatial index of every feature's envelope and a
    default style (a layer_styles row), as ogrinfo and sqlite see them."""
    done = subprocess.run([*gdal_tool("validate_gpkg"), str(path)], capture_output=True, text=True)
    assert done.returncode == 0 and done.stdout.strip() == "", done.stdout + done.stderr
    assert "HasSpatialIndex (Integer) = 1" in ogrinfo(path, "-sql", f"SELECT HasSpatialIndex('{layer}', 'geom')")
    styles = ogrinfo(path, "-sql", "SELECT f_table_name, styleName, useAsDefault FROM layer_styles")
    assert f"f_table_name (String) = {layer}" in styles and "useAsDefault (Integer(Boolean)) = 1" in styles
    with sqlite3.connect(path) as con:
        assert con.execute("SELECT extension_name, scope FROM gpkg_extensions WHERE table_name = ?",
                           (layer,)).fetchall() == [("gpkg_rtree_index", "write-only")]
        index = con.execute(f'SELECT id, minx, maxx, miny, maxy FROM "rtree_{layer}_geom" ORDER BY id').fetchall()
        qml = con.execute("SELECT styleQML FROM layer_styles WHERE f_table_name = ?", (layer,)).fetchone()[0]
    assert len(index) == features
    assert ET.fromstring(qml.split("\n", 1)[1]).find("renderer-v2").get("type") == "RuleRenderer"
    return index


def test_the_cells_geopackage_has_an_index_a_style_and_the_command_s_cells(outputs):
    out, info = outputs
    gpkg = out / "cells.gpkg"
    with sqlite3.connect(gpkg) as con:
        rows = con.execute('SELECT fid, row, col, coverage, points_a, points_b, score, lod, significant, "rank", '
                           "top_class, top_class_change, lod_ratio FROM cells").fetchall()
    index = check_geopackage(gpkg, "cells", len(rows))
    assert {r[0] for r in rows} == {i[0] for i in index}
    compared = {(c["row"], c["col"]): c for c in info["top"]}
    seen = set()
    for fid, row, col, coverage, points_a, points_b, score, lod, significant, rank, top_class, change, ratio in rows:
        if coverage == "compared":
            cell = compared[(row, col)]
            seen.add((row, col))
            assert (score, lod, bool(significant), rank) == (pytest.approx(cell["score"]), pytest.approx(cell["lod"]),
                                                            cell["significant"], cell["rank"])
            assert (points_a, points_b) == (cell["points_a"], cell["points_b"])
            assert ratio == pytest.approx(max(cell["score"] / cell["lod"], cell["height"] / cell["height_lod"]))
            assert (ratio > 1) == cell["significant"]  # the break of the map's colours
            classes = cell["classes"]  # {class: [points in A, points in B]}
            if top_class is not None:  # the class whose share changed most, in points of share
                na, nb = (sum(v[k] for v in classes.values()) for k in (0, 1))
                assert change == pytest.approx(100 * (classes[top_class][1] / nb - classes[top_class][0] / na))
        else:
            assert score is None and significant is None and rank is None and ratio is None
            assert points_a + points_b > 0
            if coverage == "appeared":
                assert points_a == 0 and points_b >= info["min_points"]
            elif coverage == "vanished":
                assert points_b == 0 and points_a >= info["min_points"]
            else:
                assert coverage == "too few points"
    assert seen == set(compared)  # every compared cell, once
    # the envelope in the index is the cell: 8 m squares on multiples of 8 m
    x0, x1, y0, y1 = index[0][1:]
    assert x1 - x0 == 8.0 and y1 - y0 == 8.0 and x0 % 8 == 0 and y0 % 8 == 0
    summary = ogrinfo("-so", gpkg, "cells")
    assert "coverage: String" in summary and f"Feature Count: {len(rows)}" in summary
    counts = info["coverage"]["cells"]  # every cell compared, appeared or vanished; sparse ones where surveyed
    states = [r[3] for r in rows]
    assert [states.count(k) for k in ("compared", "appeared", "vanished")] == \
        [counts[k] for k in ("compared", "appeared", "vanished")]
    assert states.count("too few points") <= counts["too few points"]


def test_the_cells_style_lists_only_the_rules_that_draw_a_cell_and_names_the_fields(outputs):
    # issue 48: all seven rules were listed when nothing matched; the fields were internal keys
    from lidar_sig.change_map._layers import cell_rules
    from lidar_sig.metrics import METRICS

    out, _ = outputs
    with sqlite3.connect(out / "cells.gpkg") as con:
        qml = con.execute("SELECT styleQML FROM layer_styles WHERE f_table_name = 'cells'").fetchone()[0]
        root = ET.fromstring(qml.split("\n", 1)[1])
        listed = {rule.get("filter"): rule.get("label") for rule in root.iter("rule") if rule.get("filter")}
        # a rule's filter is SQL too: SQLite counts the cells each draws
        drawn = {r.filter: con.execute(f"SELECT count(*) FROM cells WHERE {r.filter}").fetchone()[0]
                 for _, r in cell_rules()}
    assert listed and set(listed) == {f for f, n in drawn.items() if n > 0}
    assert len(drawn) > len(listed)  # this map's cells leave some rules out
    assert max(len(label) for label in listed.values()) <= 60
    aliases = {a.get("field"): a.get("name") for a in root.iter("alias")}
    assert {m.key: aliases[m.key] for m in METRICS} == {m.key: m.name for m in METRICS}
    precision = {f.get("name"): f.find(".//Option[@name='Precision']").get("value") for f in root.iter("field")}
    assert precision["kl"] == "4" and precision["lod_ratio"] == "2"


def test_the_cells_layer_holds_no_sliver_at_a_survey_s_edge_but_keeps_a_sparse_cell_inside_it():
    # issue 48: a survey's edge crossing the grid leaves a few points in the cells beyond it
    from types import SimpleNamespace

    from lidar_sig.change_map._cells import coverage as states
    from lidar_sig.change_map._layers import drawn_cells

    full = 1000
    points = np.full((5, 5), full)
    points[0, :] = 6  # a sliver row: the edge of both surveys crosses it
    points[:, 4] = 3  # and a sliver column
    points[2, 2] = 40  # a pond inside the survey: too few points, surrounded by land
    flat = points.ravel()
    valid = flat >= 200
    table = np.zeros(25, dtype=[("coverage", np.int8), ("points_a", np.int64), ("points_b", np.int64)])
    table["points_a"] = table["points_b"] = flat
    table["coverage"] = states(flat, flat, valid, 200)
    cm = SimpleNamespace(table=table, grid=SimpleNamespace(rows=5, cols=5), min_points=200, cell=10.0)
    drawn = drawn_cells(cm).reshape(5, 5)
    assert not drawn[0, :].any() and not drawn[:, 4].any()  # no sliver
    assert drawn[2, 2] and drawn[1:, :4].all()  # the pond, and every compared cell


def test_two_ign_tiles_give_cells_without_slivers(tmp_path):
    # the case: two 50 m tiles on a 25 m grid that overhangs them; every cell drawn has
    # something to say (compared, appeared, vanished, or sparse land inside a survey)
    from conftest import IGN, need_data

    folder = need_data(IGN)
    tiles = [folder / "test_data_77055_627755_LA93_IGN69.laz", folder / "test_data_77060_627755_LA93_IGN69.laz"]
    import lidar_sig
    from lidar_sig.change_map._layers import cell_features, coverage

    cm = lidar_sig.changes(tiles, tiles, cell=25)
    covered = coverage(cm.table)
    slivers = (covered == "too few points") & (cm.table["points_a"] < 0.05 * cm.min_points)
    assert slivers.sum() >= 4  # the grid overhangs the tiles
    drawn = {(f["row"], f["col"]) for _, f in cell_features(cm)}
    assert not drawn & {(int(cm.table["row"][i]), int(cm.table["col"][i])) for i in np.flatnonzero(slivers)}
    assert {(int(cm.table["row"][i]), int(cm.table["col"][i])) for i in np.flatnonzero(covered == "compared")} <= drawn


def test_the_cells_layer_names_the_coverage_state_the_change_map_gives_each_cell():
    # the states themselves are the change map's (tests/test_change_coverage.py); the layer names them
    from lidar_sig.change_map._cells import coverage as states
    from lidar_sig.change_map._layers import coverage

    points_a, points_b = np.array([500, 0, 0, 450, 30, 0]), np.array([400, 400, 12, 0, 40, 0])
    valid = np.array([True, False, False, False, False, False])
    table = np.zeros(6, dtype=[("coverage", np.int8)])
    table["coverage"] = states(points_a, points_b, valid, 100)
    assert coverage(table).tolist() == ["compared", "appeared", "too few points", "vanished", "too few points", ""]


def test_the_outliers_geopackage_has_an_index_a_style_and_marks_the_tiles_that_stand_out(tmp_path):
    cat = tmp_path / "samples.h5"
    assert run("catalog", SAMPLES, "-o", cat, "--workers", "1", "-q").returncode == 0
    done = run("outliers", cat, "-o", tmp_path / "tiles.gpkg", "--json")
    assert done.returncode == 0, done.stderr
    info = json.loads(done.stdout)
    check_geopackage(tmp_path / "tiles.gpkg", "tiles", 3)
    with sqlite3.connect(tmp_path / "tiles.gpkg") as con:
        marked = dict(con.execute('SELECT name, outlier FROM tiles').fetchall())
    assert marked == {r["name"]: int(r["outlier"]) for r in info["results"]}
    assert marked["epoch1.laz"] == 1 and sum(marked.values()) == info["standing_out"] == 1


def test_similar_tiles_are_written_with_their_footprints_to_be_seen_on_the_map(tmp_path):
    # issue 48: a table without geometry could not be seen on the map
    cat = tmp_path / "samples.h5"
    assert run("catalog", SAMPLES, "-o", cat, "--workers", "1", "-q").returncode == 0
    done = run("similar", SAMPLES / "epoch1.laz", cat, "--top", "2", "-o", tmp_path / "like.gpkg", "--json")
    assert done.returncode == 0, done.stderr
    info = json.loads(done.stdout)
    assert info["written"] == [str(tmp_path / "like.gpkg")]
    check_geopackage(tmp_path / "like.gpkg", "tiles", 2)
    from lidar_sig.survey_catalog import Catalog

    catalogue = Catalog(cat)
    with sqlite3.connect(tmp_path / "like.gpkg") as con:
        rows = con.execute('SELECT fid, "rank", name, distance, kl FROM tiles ORDER BY "rank"').fetchall()
        srs = con.execute("SELECT definition FROM gpkg_spatial_ref_sys JOIN gpkg_geometry_columns USING (srs_id) "
                          "WHERE table_name = 'tiles'").fetchone()[0]
        boxes = dict((fid, (x0, x1, y0, y1)) for fid, x0, x1, y0, y1 in
                     con.execute("SELECT id, minx, maxx, miny, maxy FROM rtree_tiles_geom"))
        qml = con.execute("SELECT styleQML FROM layer_styles WHERE f_table_name = 'tiles'").fetchone()[0]
    assert [(r, n) for _, r, n, _, _ in rows] == [(t["rank"], t["name"]) for t in info["results"]]
    assert [d for *_, d, _ in rows] == pytest.approx([t["distance"] for t in info["results"]], rel=1e-12)
    assert "Lambert-93" in srs  # the tiles' CRS
    for fid, _, name, _, _ in rows:  # each footprint the tile's convex hull
        hull = np.asarray(catalogue.columns["hull"][catalogue.columns["name"].index(name)])
        (x0, y0), (x1, y1) = hull.min(axis=0), hull.max(axis=0)
        assert boxes[fid] == pytest.approx((x0, x1, y0, y1), abs=0.25)  # the R*Tree keeps float32, rounded out
    assert 'name="delta_KL"' in qml  # the metrics by their names
    # an existing output refused, one line, the catalogue left as it was
    done = run("similar", SAMPLES / "epoch1.laz", cat, "-o", tmp_path / "like.gpkg")
    assert_one_line_error(done, "like.gpkg", "--overwrite")


# -- the later epoch's points with their cell's change ------------------------------------------

def test_the_points_carry_their_cell_s_change_with_descriptions_laspy_reads(outputs):
    import laspy

    from lidar_sig.change_map import Grid

    out, info = outputs
    las = laspy.read(out / "later.laz")
    described = {d.name: d.description for d in las.point_format.extra_dimensions}
    assert described == {"Cl": "line-type saliency Cl [0,1]", "Cs": "surface-type saliency Cs [0,1]",
                         "Cp": "point-type saliency Cp [0,1]", "Egeom": "geometric entropy [nats]",
                         "GeomClass": "1 line 2 surface 3 point 0 none",
                         "ChangeScore": "cell change score (delta_KL)",
                         "ChangeLoD": "cell level of detection of score",
                         "ChangeSignificant": "1 cell changed significantly"}
    source = laspy.read(ALIGNED)
    assert len(las.points) == len(source.points) and np.array_equal(las.x, source.x)
    a, b, c, d, e, f = info["grid"]["transform"]
    grid = Grid(c, f + e * info["grid"]["rows"], a, info["grid"]["rows"], info["grid"]["cols"])
    cells = grid.cell_of(np.column_stack([las.x, las.y]))
    by_cell = {c_["row"] * grid.cols + c_["col"]: c_ for c_ in info["top"]}
    score = np.asarray(las.ChangeScore)
    significant = np.asarray(las.ChangeSignificant)
    for flat in np.unique(cells):
        here = cells == flat
        if flat in by_cell:
            assert np.allclose(score[here], by_cell[flat]["score"], rtol=1e-6)
            assert (significant[here] == int(by_cell[flat]["significant"])).all()
        else:
            assert np.isnan(score[here]).all() and (significant[here] == 0).all()
    assert significant.sum() == sum(int(np.sum(cells == k)) for k, c_ in by_cell.items() if c_["significant"])
    # a second run on this output replaces the change dimensions instead of adding more
    from lidar_sig.io.las import lidar_sig_dims

    assert set(lidar_sig_dims(las)) == set(described)


def _cloudcompare_columns(path):
    """Open ``path`` in CloudCompare headless and save what it loaded as its own ASCII with a
    header: {name: values}."""
    done = subprocess.run(["xvfb-run", "-a", "CloudCompare", "-SILENT", "-O", str(path), "-C_EXPORT_FMT", "ASC",
                           "-ADD_HEADER", "-NO_TIMESTAMP", "-SAVE_CLOUDS"], capture_output=True, text=True,
                          timeout=300, cwd=path.parent)
    exported = path.with_suffix(".asc")
    assert exported.exists(), done.stdout[-2000:] + done.stderr[-2000:]
    with open(exported) as fh:
        names = fh.readline()[2:].split()
    rows = np.loadtxt(exported, skiprows=1, ndmin=2)
    return {name: rows[:, k] for k, name in enumerate(names)}


def test_cloudcompare_names_the_change_fields(outputs, tmp_path):
    # Debian's CloudCompare 2.11 reads no LAS/LAZ (built without its LAS plugin): the same points
    # written as PLY, whose properties it loads as named scalar fields
    if not (shutil.which("CloudCompare") and shutil.which("xvfb-run")):
        pytest.skip("CloudCompare and xvfb-run are needed (Debian: apt-get install cloudcompare xvfb)")
    import laspy

    out, _ = outputs
    done = run("changes", SAMPLES / "epoch1.laz", ALIGNED, "--cell", "8", "--points", tmp_path / "later.ply", "-q")
    assert done.returncode == 0, done.stderr
    columns = _cloudcompare_columns(tmp_path / "later.ply")
    assert {"ChangeScore", "ChangeLoD", "ChangeSignificant", "Cl", "GeomClass"} <= set(columns)
    las = laspy.read(out / "later.laz")  # the same run's LAS: the same values, point by point
    np.testing.assert_array_equal(columns["ChangeSignificant"], np.asarray(las.ChangeSignificant))
    # CloudCompare writes 6 significant digits
    np.testing.assert_allclose(columns["ChangeScore"], np.asarray(las.ChangeScore), rtol=1e-5, equal_nan=True)


# -- refusals ---------------------------------------------------------------------------------

def test_wrong_cells_and_points_outputs_are_refused_before_any_work(tmp_path):
    done = run("changes", SAMPLES / "epoch1.laz", ALIGNED, "--cells", tmp_path / "cells.shp")
    assert_one_line_error(done, "cells.shp", ".gpkg")
    done = run("changes", SAMPLES / "epoch1.laz", ALIGNED, "--points", tmp_path / "later.tif")
    assert_one_line_error(done, "later.tif", ".laz")
    done = run("changes", SAMPLES / "epoch1.laz", ALIGNED, SAMPLES / "epoch2.laz", "--points", tmp_path / "p.laz")
    assert_one_line_error(done, "p.laz", "two epochs")
    assert list(tmp_path.iterdir()) == []
