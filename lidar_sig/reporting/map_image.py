"""The pictures of a change map (:mod:`lidar_sig.change_map`), made to read like a map: each
cell filled with its colour on the one colour scale of change
(:mod:`lidar_sig.reporting.change_scale`: a compared cell by how far it lies from its level of
detection, every other cell by its coverage state), the cells that changed significantly
outlined, the most changed numbered; framed by the CRS coordinates of the cell edges, with a
north arrow, a scale bar, the CRS name and the scale's legend below. The map of a series'
"when" band over a grey top view of the last epoch, one colour per interval.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..numerics.bounds import column_min
from .change_scale import CHANGE_SCALE, table_colours

#: ColorBrewer Set1 (less its yellow), one colour per interval of a series' "when" map.
INTERVALS = np.array([(55, 126, 184), (228, 26, 28), (77, 175, 74), (152, 78, 163), (255, 127, 0),
                      (166, 86, 40), (247, 129, 191), (153, 153, 153)], dtype=np.float64)
#: The names of those colours, for legends in words.
INTERVAL_NAMES = ("blue", "red", "green", "purple", "orange", "brown", "pink", "grey")
#: Opacity of the colours of cells that changed significantly, and of the others (faded).
ALPHA = 0.8
FADED = 0.25
#: Cells numbered on the map and shown in the report.
TOP = 5
#: Margins around the map (px): left for the northings, bottom for the eastings.
LEFT, BOTTOM, TOP_MARGIN, RIGHT = 84, 34, 12, 16
#: The north arrow's box (px), in the map's top-right corner.
ARROW = 34
_INK = (20, 20, 20)
_GRID = (150, 150, 150)
#: Colour of the cells with points never compared on a series' "when" map.
_NODATA = CHANGE_SCALE.states["too few points"][0]
_FONT = 0  # cv2.FONT_HERSHEY_SIMPLEX
#: Size of the text (legend, ticks, CRS line): letters 11 px or taller shown at the picture's size.
_SMALL = 0.5
#: Height of a legend's row (px), and the legend's least width.
_ROW = 24
LEGEND_WIDTH = 760


@dataclass(frozen=True)
class Layout:
    """Where a map picture's parts are, in px of the picture: the map's top-left corner and
    size, the north arrow's box (x, y, w, h), the legend's first row."""

    map_x: int
    map_y: int
    map_w: int
    map_h: int
    arrow: tuple
    legend_y: int


def layout(grid, display=640):
    """The :class:`Layout` of the picture of ``grid`` drawn at about ``display`` px."""
    width, height = grid.cols * grid.size, grid.rows * grid.size
    factor = display / max(width, height)
    return _layout(max(1, round(width * factor)), max(1, round(height * factor)))


def _layout(w, h):
    return Layout(LEFT, TOP_MARGIN, w, h, (LEFT + w - ARROW - 4, TOP_MARGIN + 4, ARROW, ARROW), TOP_MARGIN + h + BOTTOM)


def cell_edges(grid, display):
    """The cells' pixel edges (x edges, y edges) of ``grid`` drawn at about ``display`` px."""
    lay = layout(grid, display)
    factor = lay.map_w / (grid.cols * grid.size)  # display px per CRS unit
    return (np.rint(np.arange(grid.cols + 1) * grid.size * factor).astype(int),
            np.rint(np.arange(grid.rows + 1) * grid.size * factor).astype(int))


def cells_picture(change_map, *, display=640, top=TOP, scale=CHANGE_SCALE):
    """(H, W, 3) uint8: the cells of a change map alone (row 0 north), each filled with its
    colour on ``scale`` (:func:`~lidar_sig.reporting.change_scale.table_colours`), the
    significant ones outlined dark in a light halo, the ``top`` most changed numbered; and the
    cells' pixel edges. The map of :func:`change_map_image` and a notebook card's picture."""
    cm = change_map
    edges = cell_edges(cm.grid, display)
    rgb = np.zeros((edges[1][-1], edges[0][-1], 3), np.uint8)
    out = _paint_cells(rgb, cm.grid, edges, table_colours(cm.table, scale, cm.drawn()), cm.table["significant"],
                        scale)
    _numbers(out, cm.grid, edges, cm.ranked(top))
    return out, edges


def change_map_image(change_map, *, display=640, top=TOP):
    """(H, W, 3) uint8 map of a change map's cells in the one colour scale of change
    (:data:`~lidar_sig.reporting.change_scale.CHANGE_SCALE`: each compared cell by how far it
    lies from its level of detection, every other cell by its coverage state), significant cells
    outlined, the ``top`` most changed numbered (:func:`cells_picture`); coordinates, north
    arrow, scale bar, CRS and the scale's legend around it."""
    cm = change_map
    rgb, edges = cells_picture(cm, display=display, top=top)
    legend = _scale_legend(cm, max(rgb.shape[1] + LEFT + RIGHT, LEGEND_WIDTH))
    return _framed(rgb, cm.grid, edges, cm.crs, cm.units, legend)


def when_map_image(series, *, display=640):
    """(H, W, 3) uint8 map of a series' "when": each cell that changed significantly in the
    colour of the interval in which it changed most, cells compared but never significant
    faded, cells with points but never compared grey; framed as :func:`change_map_image`."""
    last = series.maps[-1]
    e = series.epochs[-1]
    rgb, edges = _backdrop(series.grid, e.used(e.cloud.xyz), e.used(e.saliency.values), display)
    when = series.when().ravel()  # in the table's order
    changed = np.nan_to_num(when) > 0
    compared = ~np.isnan(when)
    index = np.clip(np.nan_to_num(when).astype(int) - 1, 0, None) % len(INTERVALS)
    colours = np.where(changed[:, None], INTERVALS[index], 255.0)
    alpha = np.where(changed, ALPHA, FADED)
    points = sum((m.table["points_a"] > 0) | (m.table["points_b"] > 0) for m in series.maps) > 0
    rgb = _paint(rgb, series.grid, edges, colours, alpha, compared, changed, points & ~compared)
    legend = _when_legend(series)
    return _framed(rgb, series.grid, edges, last.crs, last.units, legend)


def _backdrop(grid, xyz, saliency, display):
    """A light grey top view placed in the grid's extent (float RGB) and the cells' pixel edges."""
    import cv2

    from .render import top_view

    view, px = top_view(xyz, saliency)
    grey = cv2.cvtColor(view, cv2.COLOR_RGB2GRAY)
    grey = (255 - 0.55 * (255 - grey.astype(np.float64))).astype(np.uint8)  # a light backdrop
    lay = layout(grid, display)
    factor = lay.map_w / (grid.cols * grid.size)  # display px per CRS unit
    canvas = np.full((lay.map_h, lay.map_w), 255, np.uint8)
    lo = column_min(xyz[:, :2])
    hi_y = xyz[:, 1].max()
    scaled = cv2.resize(grey, (max(1, round(view.shape[1] * px * factor)), max(1, round(view.shape[0] * px * factor))),
                        interpolation=cv2.INTER_AREA)
    # the top view starts at the epoch's own lower-left point
    x_off = round((lo[0] - grid.x0) * factor)
    y_off = round((grid.y0 + grid.rows * grid.size - hi_y) * factor)
    h, w = min(scaled.shape[0], lay.map_h - y_off), min(scaled.shape[1], lay.map_w - x_off)
    canvas[y_off:y_off + h, x_off:x_off + w] = scaled[:h, :w]
    return np.repeat(canvas[..., None], 3, axis=2).astype(np.float64), cell_edges(grid, display)


def _paint(rgb, grid, edges, colours, alpha, coloured, outlined, nodata):
    """Cells coloured over the backdrop (``alpha`` per cell), grid lines, ``outlined`` cells
    framed in ink, ``nodata`` cells greyed; uint8."""
    import cv2

    h, w = rgb.shape[:2]
    for c in np.flatnonzero(coloured | nodata):
        r, k = divmod(int(c), grid.cols)
        ys, xs = slice(edges[1][r], edges[1][r + 1]), slice(edges[0][k], edges[0][k + 1])
        if coloured[c]:
            rgb[ys, xs] = (1 - alpha[c]) * rgb[ys, xs] + alpha[c] * colours[c]
        else:
            rgb[ys, xs] = 0.5 * rgb[ys, xs] + 0.5 * np.asarray(_NODATA)
    out = np.rint(rgb).astype(np.uint8)
    for x in edges[0]:
        cv2.line(out, (min(x, w - 1), 0), (min(x, w - 1), h - 1), (150, 150, 150), 1)
    for y in edges[1]:
        cv2.line(out, (0, min(y, h - 1)), (w - 1, min(y, h - 1)), (150, 150, 150), 1)
    for c in np.flatnonzero(outlined):
        r, k = divmod(int(c), grid.cols)
        cv2.rectangle(out, (edges[0][k] + 1, edges[1][r] + 1), (min(edges[0][k + 1], w) - 2, min(edges[1][r + 1], h) - 2),
                      CHANGE_SCALE.outline, 2)
    return out


def _paint_cells(rgb, grid, edges, colours, outlined, scale):
    """Each cell filled with its colour (opaque: the colour a face shows is the scale's), grid
    lines, ``outlined`` cells framed dark in a light halo (seen on the lightest and the darkest
    class alike); uint8."""
    import cv2

    h, w = rgb.shape[:2]
    out = rgb.copy()
    for c in range(grid.n_cells):
        r, k = divmod(c, grid.cols)
        out[edges[1][r]:edges[1][r + 1], edges[0][k]:edges[0][k + 1]] = colours[c]
    for x in edges[0]:
        cv2.line(out, (min(x, w - 1), 0), (min(x, w - 1), h - 1), _GRID, 1)
    for y in edges[1]:
        cv2.line(out, (0, min(y, h - 1)), (w - 1, min(y, h - 1)), _GRID, 1)
    side = min(edges[0][1] - edges[0][0], edges[1][1] - edges[1][0]) if grid.n_cells else 0
    # halo, outline, halo (px) as the cells allow: a halo on both sides of the outline from 12 px
    line = 2 if side >= 30 else 1
    for c in np.flatnonzero(outlined):
        r, k = divmod(int(c), grid.cols)
        x0, y0, x1, y1 = edges[0][k], edges[1][r], min(edges[0][k + 1], w) - 1, min(edges[1][r + 1], h) - 1
        if side >= 12:
            cv2.rectangle(out, (x0 + 1, y0 + 1), (x1 - 1, y1 - 1), scale.halo, 1)
            for d in range(2, 2 + line):
                cv2.rectangle(out, (x0 + d, y0 + d), (x1 - d, y1 - d), scale.outline, 1)
            cv2.rectangle(out, (x0 + 2 + line, y0 + 2 + line), (x1 - 2 - line, y1 - 2 - line), scale.halo, 1)
        else:
            cv2.rectangle(out, (x0, y0), (x1, y1), scale.outline, 1)
    return out


def _numbers(rgb, grid, edges, cells, scale=CHANGE_SCALE):
    """Each of ``cells`` numbered by its rank (1 first) at its centre, in the outline's ink on a
    halo of its light colour; smaller in small cells."""
    import cv2

    side = min(edges[0][1] - edges[0][0], edges[1][1] - edges[1][0]) if len(edges[0]) > 1 else 0
    size, weight = (0.5, 2) if side >= 30 else (0.35, 1)
    for rank, c in enumerate(cells, 1):
        r, k = divmod(int(c), grid.cols)
        text = str(rank)
        (tw, th), _ = cv2.getTextSize(text, _FONT, size, weight)
        org = ((edges[0][k] + edges[0][k + 1] - tw) // 2, (edges[1][r] + edges[1][r + 1] + th) // 2)
        cv2.putText(rgb, text, org, _FONT, size, scale.halo, weight + 2, cv2.LINE_AA)
        cv2.putText(rgb, text, org, _FONT, size, scale.outline, weight, cv2.LINE_AA)


def _framed(map_rgb, grid, edges, crs, units, legend):
    """The map in its frame: eastings below and northings left of the cell edges (CRS
    coordinates, every few cells), a north arrow, then the legend with a scale bar and the CRS
    name."""
    import cv2

    from ..method.crs import crs_name
    from .render import scale_bar

    h, w = map_rgb.shape[:2]
    width = max(LEFT + w + RIGHT, legend.shape[1])
    out = np.full((TOP_MARGIN + h + BOTTOM, width, 3), 255, np.uint8)
    out[TOP_MARGIN:TOP_MARGIN + h, LEFT:LEFT + w] = map_rgb
    cv2.rectangle(out, (LEFT - 1, TOP_MARGIN - 1), (LEFT + w, TOP_MARGIN + h), _INK, 1)
    cell_px = max(edges[0][1] - edges[0][0], 1)
    step = next(s for s in (1, 2, 5, 10, 20, 50, 100, 200, 500, 1000, 10 ** 9) if s * cell_px >= 80)
    for k in range(0, grid.cols + 1, step):  # eastings of the cell edges
        x = LEFT + min(edges[0][k], w)
        cv2.line(out, (x, TOP_MARGIN + h), (x, TOP_MARGIN + h + 5), _INK, 1)
        text = f"{grid.x0 + k * grid.size:.0f}"
        (tw, th), _ = cv2.getTextSize(text, _FONT, _SMALL, 1)
        cv2.putText(out, text, (max(0, min(x - tw // 2, width - tw)), TOP_MARGIN + h + 9 + th), _FONT, _SMALL, _INK,
                    1, cv2.LINE_AA)
    for r in range(0, grid.rows + 1, step):  # northings of the cell edges
        y = TOP_MARGIN + min(edges[1][r], h)
        cv2.line(out, (LEFT - 6, y), (LEFT - 1, y), _INK, 1)
        text = f"{grid.y0 + (grid.rows - r) * grid.size:.0f}"
        (tw, th), _ = cv2.getTextSize(text, _FONT, _SMALL, 1)
        cv2.putText(out, text, (LEFT - 9 - tw, min(max(y + th // 2, th), TOP_MARGIN + h + th)), _FONT, _SMALL, _INK, 1,
                    cv2.LINE_AA)
    _north_arrow(out, _layout(w, h).arrow)
    metres_per_px = grid.size * units.horizontal / cell_px
    bar, label = scale_bar(metres_per_px, min(200, w // 2), "m")
    foot = np.full((50, width, 3), 255, np.uint8)
    cv2.line(foot, (12, 12), (12 + bar, 12), _INK, 3)
    for x in (12, 12 + bar):
        cv2.line(foot, (x, 6), (x, 18), _INK, 1)
    cv2.putText(foot, label, (18 + bar, 17), _FONT, _SMALL, _INK, 1, cv2.LINE_AA)
    name = crs_name(crs) or "no CRS (coordinates as given)"
    cv2.putText(foot, f"CRS: {name}; eastings and northings of the cell edges; north up", (12, 42), _FONT, _SMALL,
                _INK, 1, cv2.LINE_AA)
    pad = np.full((legend.shape[0], width, 3), 255, np.uint8)
    pad[:, :legend.shape[1]] = legend
    return np.vstack([out, foot, pad])


def _north_arrow(out, box):
    import cv2

    x, y, w, h = box
    cv2.rectangle(out, (x, y), (x + w, y + h), (255, 255, 255), -1)
    cv2.rectangle(out, (x, y), (x + w, y + h), _INK, 1)
    cx = x + w // 2
    tip, base = y + 4, y + h - 14
    cv2.fillConvexPoly(out, np.array([[cx, tip], [cx - 7, base], [cx, base - 5], [cx + 7, base]], np.int32), _INK)
    (tw, th), _ = cv2.getTextSize("N", _FONT, _SMALL, 1)
    cv2.putText(out, "N", (cx - tw // 2, y + h - 2), _FONT, _SMALL, _INK, 1, cv2.LINE_AA)


def _swatch(legend, x, y, colour, outlined, scale=CHANGE_SCALE, alpha=1.0):
    """A legend's swatch at (x, y): ``colour`` (blended at ``alpha`` over white), framed thin
    grey, or outlined as a significant cell is on the map."""
    import cv2

    fill = tuple(int(round((1 - alpha) * 255 + alpha * c)) for c in colour)
    cv2.rectangle(legend, (x, y), (x + 20, y + 16), fill, -1)
    if outlined:
        cv2.rectangle(legend, (x, y), (x + 20, y + 16), scale.outline, 2)
        cv2.rectangle(legend, (x + 2, y + 2), (x + 18, y + 14), scale.halo, 1)
    else:
        cv2.rectangle(legend, (x, y), (x + 20, y + 16), _GRID, 1)


def _scale_legend(cm, width, scale=CHANGE_SCALE):
    """The legend of the one colour scale: its title, every class of lod_ratio (two columns),
    every coverage state with its count, the outline of a significant cell and the ranks."""
    import cv2

    rows = (len(scale.classes) + 1) // 2
    column = width // 2
    coverage = cm.coverage()
    states = [(rgb, f"{label}: {coverage.get(name, 0):,}") for name, (rgb, label) in scale.states.items()]
    n_rows = 1 + rows + (len(states) + 1) // 2 + 1
    legend = np.full((10 + _ROW * n_rows, width, 3), 255, np.uint8)
    _text(legend, f"colour: how far each {cm.cell:g} m cell's {cm.score_name} (or delta_H) lies from its level of "
          "detection (lod_ratio)", 12, 10 + _ROW - 8)
    y = 10 + _ROW
    for i, (_, rgb, label) in enumerate(scale.classes):
        x, yy = 12 + column * (i // rows), y + _ROW * (i % rows)
        _swatch(legend, x, yy, rgb, False)
        _text(legend, label, x + 26, yy + 13)
    y += _ROW * rows
    for i, (rgb, label) in enumerate(states):
        x, yy = 12 + column * (i % 2), y + _ROW * (i // 2)
        _swatch(legend, x, yy, rgb, False)
        _text(legend, label, x + 26, yy + 13)
    y += _ROW * ((len(states) + 1) // 2)
    _swatch(legend, 12, y, scale.classes[-3][1], True, scale)
    _text(legend, f"outlined: changed significantly ({cm.confidence:.0%}), {cm.n_significant:,} of "
          f"{int(cm.table['valid'].sum()):,} compared; 1, 2, ...: rank, most changed first", 38, y + 13)
    return legend


def _text(image, text, x, y):
    import cv2

    cv2.putText(image, text, (x, y), _FONT, _SMALL, _INK, 1, cv2.LINE_AA)


def _when_legend(series):
    import cv2

    n = len(series.maps)
    legend = np.full((26 + _ROW * (n + 1), LEGEND_WIDTH, 3), 255, np.uint8)
    cv2.putText(legend, "when: the interval in which the cell changed most (significant cells)", (12, 16), _FONT,
                _SMALL, _INK, 1, cv2.LINE_AA)
    when = series.when()
    for k in range(n):
        y = 26 + _ROW * k
        _swatch(legend, 12, y, tuple(INTERVALS[k % len(INTERVALS)]), True, alpha=ALPHA)
        cv2.putText(legend, f"{series.interval_name(k)}: {int((when == k + 1).sum()):,} cells", (38, y + 13), _FONT,
                    _SMALL, _INK, 1, cv2.LINE_AA)
    y = 26 + _ROW * n
    _swatch(legend, 12, y, (255, 255, 255), False, alpha=FADED)
    cv2.putText(legend, f"compared, never significant: {int((when == 0).sum()):,} cells; slate: not compared",
                (38, y + 13), _FONT, _SMALL, _INK, 1, cv2.LINE_AA)
    return legend
