"""One change map, one colour scale (issue 48, must-show 1): for the IGN edited pair and for an
epoch against itself, every cell has the same colour in the GeoTIFF's QGIS style (with the
cells' style for the cells not compared), the PNG map, the notebook card's picture and the
report's map; identical epochs show no warm colour anywhere; the cell of rank 1 is drawn in the
strongest class. The faces are read back from what they wrote: the QML and the GeoTIFF's band,
the GeoPackage's style and features, and the pixels of each picture."""
import base64
import importlib.util
import re
import sqlite3
import sys
import xml.etree.ElementTree as ET

import numpy as np
import pytest

from conftest import IGN, ROOT, need_data

TILES = ("test_data_77055_627755_LA93_IGN69.laz", "test_data_77060_627755_LA93_IGN69.laz")

needs_geo = pytest.mark.skipif(importlib.util.find_spec("rasterio") is None,
                               reason="rasterio not installed: pip install -e '.[geo]'")


@pytest.fixture(scope="module")
def maps():
    """{"edited": the two IGN tiles against their edited copy, "same": the tiles against themselves}."""
    need_data(IGN)
    sys.path.insert(0, str(ROOT / "benchmarks"))
    from edited_epoch import edit

    from lidar_sig.change_map import changes, compute_epoch, read_epoch

    one = read_epoch([IGN / name for name in TILES])
    two, edits = edit(one)
    first = compute_epoch(one)
    edited = changes(first, compute_epoch(two), cell=10)
    cells = {int(edited.grid.cell_of(np.array([xy]))[0]) for xy in edits.values()}
    return {"edited": edited, "same": changes(first, first, cell=10)}, cells


def _mode(pixels):
    """The most frequent colour of (N, 3) pixels but the outline's and its halo's: a cell's fill,
    whatever its outline and rank number (drawn in those two colours)."""
    from lidar_sig.reporting.change_scale import CHANGE_SCALE

    colours, counts = np.unique(pixels.reshape(-1, 3), axis=0, return_counts=True)
    ink = (colours == CHANGE_SCALE.outline).all(axis=1) | (colours == CHANGE_SCALE.halo).all(axis=1)
    counts[ink] = 0
    return tuple(int(c) for c in colours[np.argmax(counts)])


def _cell_colours(picture, x0, y0, edges, grid):
    """(cells, 3) the fill of each cell of a map picture whose map starts at (x0, y0) with the
    cells' pixel ``edges``: the mode of the cell's inside (its outline and halo left out)."""
    out = np.zeros((grid.n_cells, 3), int)
    for c in range(grid.n_cells):
        r, k = divmod(c, grid.cols)
        ys, ye = y0 + edges[1][r], y0 + edges[1][r + 1]
        xs, xe = x0 + edges[0][k], x0 + edges[0][k + 1]
        inset = max(1, (xe - xs) // 6)
        out[c] = _mode(picture[ys + inset:ye - inset, xs + inset:xe - inset])
    return out


def _png(data):
    import cv2

    return cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_COLOR)[:, :, ::-1]


def _rgb(text):
    """(r, g, b) of a QML colour: "#rrggbb" or "r,g,b,a"."""
    if text.startswith("#"):
        return tuple(int(text[i:i + 2], 16) for i in (1, 3, 5))
    return tuple(int(v) for v in text.split(",")[:3])


def qgis_colours(cm, folder):
    """(cells, 3): each cell as QGIS draws it from the saved files: the GeoTIFF's band in its
    QML's discrete classes (no data in the QML's no-data colour), under the GeoPackage cells
    whose style fills them (the cells not compared) in their rule's colour."""
    import rasterio

    cm.save(folder / "map.tif")
    cm.save(folder / "cells.gpkg")
    style = ET.parse(folder / "map.qml").getroot()
    renderer = style.find(".//rasterrenderer")
    items = [(float(i.get("value")), _rgb(i.get("color"))) for i in style.iter("item")]
    assert style.find(".//colorrampshader").get("colorRampType") == "DISCRETE"
    with rasterio.open(folder / "map.tif") as src:
        values = src.read(int(renderer.get("band"))).ravel().astype(float)
        nodata = src.nodata
    out = np.zeros((cm.grid.n_cells, 3), int)
    for c, v in enumerate(values):
        # QGIS's discrete ramp: a value takes the colour of the first class it does not exceed
        out[c] = _rgb(renderer.get("nodataColor")) if v == nodata else next(rgb for bound, rgb in items if v <= bound)
    with sqlite3.connect(folder / "cells.gpkg") as db:
        qml = db.execute("SELECT styleQML FROM layer_styles WHERE useAsDefault").fetchone()[0]
        features = db.execute("SELECT row, col, coverage FROM cells").fetchall()
    cells = ET.fromstring(qml.split("\n", 1)[1])
    fills = {}
    for rule in cells.iter("rule"):
        symbol = cells.find(f".//symbols/symbol[@name='{rule.get('symbol')}']")
        options = {o.get("name"): o.get("value") for o in symbol.findall("layer")[-1].iter("Option")}
        state = re.search(r"\"coverage\" = '([^']+)'", rule.get("filter") or "")
        if state and options.get("style") == "solid" and int(options["color"].split(",")[3]) == 255:
            fills[state.group(1)] = _rgb(options["color"])
    for row, col, state in features:
        if state in fills:  # drawn above the map, opaque
            out[row * cm.grid.cols + col] = fills[state]
    return out


def png_colours(cm, folder):
    from lidar_sig.reporting.map_image import cell_edges, layout

    import cv2

    cm.save(folder / "map.png")
    picture = cv2.imread(str(folder / "map.png"))[:, :, ::-1]
    lay = layout(cm.grid)
    return _cell_colours(picture, lay.map_x, lay.map_y, cell_edges(cm.grid, 640), cm.grid)


def card_colours(cm):
    from lidar_sig.reporting.map_image import cell_edges

    found = re.search(r'<img src="data:image/png;base64,([^"]+)"', cm._repr_html_())
    picture = _png(base64.b64decode(found.group(1)))
    return _cell_colours(picture, 0, 0, cell_edges(cm.grid, picture.shape[1] if cm.grid.cols >= cm.grid.rows
                                                            else picture.shape[0]), cm.grid)


def report_colours(cm):
    from lidar_sig.reporting.map_image import cell_edges, layout

    found = re.search(r'<img src="data:image/png;base64,([^"]+)" alt="change map"', cm.report().html())
    picture = _png(base64.b64decode(found.group(1)))
    lay = layout(cm.grid)
    return _cell_colours(picture, lay.map_x, lay.map_y, cell_edges(cm.grid, 640), cm.grid)


@needs_geo
def test_every_face_colours_each_cell_alike_and_rank_1_strongest(maps, tmp_path):
    from lidar_sig.reporting.change_scale import CHANGE_SCALE, table_colours

    found, edits = maps
    warm = {tuple(int(v) for v in rgb) for rgb in CHANGE_SCALE.colours[CHANGE_SCALE.warm]}
    strength = {tuple(int(v) for v in rgb): k for k, rgb in enumerate(CHANGE_SCALE.colours)}
    for name, cm in found.items():
        folder = tmp_path / name
        folder.mkdir()
        scale = table_colours(cm.table, drawn=cm.drawn()).astype(int)  # the slivers of a survey's edge as not covered
        faces = {"QGIS": qgis_colours(cm, folder), "PNG": png_colours(cm, folder), "card": card_colours(cm),
                 "report": report_colours(cm)}
        valid = cm.table["valid"]
        assert valid.sum() >= 15
        for face, colours in faces.items():
            differ = np.flatnonzero((colours != scale).any(axis=1))
            assert not len(differ), (name, face, [(int(c), colours[c].tolist(), scale[c].tolist()) for c in differ[:5]])
            classes = np.array([strength.get(tuple(c), -1) for c in colours])
            first = int(cm.ranked(1)[0])
            assert classes[first] == classes[valid].max(), (name, face)  # rank 1 drawn strongest
            drawn_warm = {tuple(c) for c in colours.tolist()} & warm
            if name == "same":
                assert not drawn_warm, (face, drawn_warm)  # an epoch against itself: no warm colour
            else:
                # each edit warm, or (the building removed whole, in 10 m cells) vanished
                changed = warm | {CHANGE_SCALE.states[s][0] for s in ("appeared", "vanished")}
                assert drawn_warm and all(tuple(colours[c]) in changed for c in edits), face
    assert found["same"].n_significant == 0 and found["edited"].table["changed"][list(edits)].all()
    # every state not compared has a colour of its own, none white and none a class's
    states = [rgb for rgb, _ in CHANGE_SCALE.states.values()]
    assert len(set(states)) == len(states) and (255, 255, 255) not in states
    assert not set(states) & {tuple(int(v) for v in rgb) for rgb in CHANGE_SCALE.colours}


def test_the_ranking_orders_the_cells_by_the_quantity_they_are_coloured_by(maps):
    from lidar_sig.reporting.change_scale import CHANGE_SCALE

    cm = maps[0]["edited"]
    order = cm.ranked()
    significant = cm.table["significant"][order]
    assert significant[:significant.sum()].all()  # the significant cells first
    ratio = cm.table[CHANGE_SCALE.quantity][order]
    for part in (ratio[significant], ratio[~significant]):
        assert (np.diff(part) <= 0).all()  # then by lod_ratio, largest first: the class never rises


def test_the_report_shows_the_map_at_its_own_size_with_text_of_11_px_or_more(tmp_path):
    # the map's text (ticks, CRS line, legend) was 8 to 9 px on screen: a 740 px picture shrunk
    # into one of two columns
    from browser import Browser, missing
    from conftest import SAMPLES

    import lidar_sig as ls

    cm = ls.changes(SAMPLES / "epoch1.laz", SAMPLES / "epoch2_aligned.laz", cell=8,
                    pipeline=ls.Pipeline(progress=False))
    html = cm.report().html()
    found = re.search(r'<img src="data:image/png;base64,([^"]+)" alt="change map"', html)
    picture = _png(base64.b64decode(found.group(1)))
    # the CRS line: the last band of ink between the map's foot and the legend
    from lidar_sig.reporting.map_image import layout

    lay = layout(cm.grid)
    ink = (picture[lay.legend_y:lay.legend_y + 60, :400].max(axis=2) < 100).any(axis=1)
    bands = np.split(np.arange(len(ink)), np.flatnonzero(np.diff(ink.astype(int))) + 1)
    heights = [len(b) for b in bands if ink[b[0]]]
    assert heights and max(heights) >= 11, heights
    why = missing()
    if why:
        pytest.skip(f"no headless browser to show the report ({why})")
    (tmp_path / "report.html").write_text(html, encoding="utf-8")
    with Browser(width=1280) as browser:
        browser.open(tmp_path / "report.html")
        shown, natural = browser.driver.execute_script(
            "const i = document.querySelector('img[alt=\"change map\"]'); return [i.clientWidth, i.naturalWidth];")
    assert natural == picture.shape[1] and shown == natural, (shown, natural)  # shown at its size: 1 px a px
