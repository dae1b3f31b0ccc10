"""The pictures of a change map (:mod:`lidar_sig.change_map`), made to read like a map: each
compared cell coloured by its score over a grey top view of one epoch (north up), the cells that
changed significantly at full colour and outlined, the others faded, cells that only one epoch
covers (appeared, vanished) in colours of their own, cells with too few points grey, the most
changed numbered; framed by the CRS coordinates of the cell edges, with a north arrow,
a scale bar, the CRS name and a legend below. The map of a series' "when" band alike, one colour
per interval.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..base.errors import counted
from ..numerics.bounds import column_min

#: ColorBrewer YlOrRd, light (no change) to dark red (most change), for the score.
SEQUENTIAL = np.array([(255, 255, 204), (255, 237, 160), (254, 217, 118), (254, 178, 76), (253, 141, 60),
                       (252, 78, 42), (227, 26, 28), (189, 0, 38), (128, 0, 38)], dtype=np.float64)
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
_NODATA = (170, 170, 170)
#: Colours of the cells not compared that one epoch covers: only the later (appeared), only the
#: earlier (vanished); cells both cover with too few points are grey (docs/changes.md, coverage).
APPEARED = (33, 113, 181)
VANISHED = (136, 65, 157)
#: Colour of the outline of a cell that changed significantly.
OUTLINE = (20, 20, 20)
_FONT = 0  # cv2.FONT_HERSHEY_SIMPLEX
_SMALL = 0.4


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


def change_map_image(change_map, epoch="b", *, display=640, top=TOP):
    """(H, W, 3) uint8 map of the score per cell over a grey top view of epoch ``"a"`` or
    ``"b"``: significant cells outlined at full colour, others faded, cells that only one epoch
    covers in the colour of their state (appeared, vanished), those both cover with too few
    points grey, the ``top`` most changed numbered; coordinates, north arrow, scale bar, CRS
    and legend around it."""
    from .render import ramp

    cm = change_map
    e = cm.a if epoch == "a" else cm.b
    rgb, edges = _backdrop(cm.grid, *e.view(), display)
    t = cm.table
    valid, significant = t["valid"], t["significant"]
    top_value = float(np.nanmax(t["score"][valid])) if valid.any() else 1.0
    colours = ramp(np.nan_to_num(t["score"] / (top_value or 1.0)), SEQUENTIAL).astype(np.float64)
    alpha = np.where(significant, ALPHA, FADED)
    state = t["coverage"]
    for code, colour in ((2, APPEARED), (3, VANISHED)):  # COVERAGE's codes
        colours[state == code] = colour
        alpha[state == code] = 0.6
    rgb = _paint(rgb, cm.grid, edges, colours, alpha, valid | (state == 2) | (state == 3), significant, state == 4)
    _numbers(rgb, cm.grid, edges, cm.ranked(top))
    legend = _score_legend(cm, top_value)
    return _framed(rgb, cm.grid, edges, cm.crs, cm.units, legend)


def when_map_image(series, *, display=640):
    """(H, W, 3) uint8 map of a series' "when": each cell that changed significantly in the
    colour of the interval in which it changed most, cells compared but never significant
    faded, cells with points but never compared grey; framed as :func:`change_map_image`."""
    last = series.maps[-1]
    e = series.epochs[-1]
    rgb, edges = _backdrop(series.grid, e.used(e.cloud.xyz), e.used(e.saliency.values), display)
    when = series.when()
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
    edges = (np.rint(np.arange(grid.cols + 1) * grid.size * factor).astype(int),
             np.rint(np.arange(grid.rows + 1) * grid.size * factor).astype(int))
    return np.repeat(canvas[..., None], 3, axis=2).astype(np.float64), edges


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
                      OUTLINE, 2)
    return out


def _numbers(rgb, grid, edges, cells):
    import cv2

    for rank, c in enumerate(cells, 1):
        r, k = divmod(int(c), grid.cols)
        text = str(rank)
        (tw, th), _ = cv2.getTextSize(text, _FONT, 0.5, 2)
        org = ((edges[0][k] + edges[0][k + 1] - tw) // 2, (edges[1][r] + edges[1][r + 1] + th) // 2)
        cv2.putText(rgb, text, org, _FONT, 0.5, (255, 255, 255), 4, cv2.LINE_AA)
        cv2.putText(rgb, text, org, _FONT, 0.5, _INK, 2, cv2.LINE_AA)


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
    foot = np.full((44, width, 3), 255, np.uint8)
    cv2.line(foot, (12, 12), (12 + bar, 12), _INK, 3)
    for x in (12, 12 + bar):
        cv2.line(foot, (x, 6), (x, 18), _INK, 1)
    cv2.putText(foot, label, (18 + bar, 17), _FONT, _SMALL, _INK, 1, cv2.LINE_AA)
    name = crs_name(crs) or "no CRS (coordinates as given)"
    cv2.putText(foot, f"CRS: {name}; eastings and northings of the cell edges; north up", (12, 36), _FONT, _SMALL,
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


def _swatch(legend, x, y, colour, alpha, outlined):
    import cv2

    fill = tuple(int(round((1 - alpha) * 235 + alpha * c)) for c in colour)
    cv2.rectangle(legend, (x, y), (x + 16, y + 12), fill, -1)
    cv2.rectangle(legend, (x, y), (x + 16, y + 12), OUTLINE if outlined else (150, 150, 150), 2 if outlined else 1)


def _score_legend(cm, top_value):
    import cv2

    from .render import ramp

    width = 620
    legend = np.full((118, width, 3), 255, np.uint8)
    x0, x1 = 12, 230
    legend[8:20, x0:x1] = ramp(np.linspace(0.0, 1.0, x1 - x0), SEQUENTIAL)[None]
    cv2.rectangle(legend, (x0, 8), (x1 - 1, 19), (90, 90, 90), 1)
    cv2.putText(legend, "0", (x0, 34), _FONT, _SMALL, _INK, 1, cv2.LINE_AA)
    text = f"{top_value:.3g}"
    (tw, _), _ = cv2.getTextSize(text, _FONT, _SMALL, 1)
    cv2.putText(legend, text, (x1 - tw, 34), _FONT, _SMALL, _INK, 1, cv2.LINE_AA)
    name = cm.score_name
    cv2.putText(legend, f"score: {name} per {cm.cell:g} m cell", (x1 + 12, 18), _FONT, _SMALL, _INK, 1, cv2.LINE_AA)
    mid = tuple(SEQUENTIAL[5])
    _swatch(legend, x0, 44, mid, ALPHA, True)
    cv2.putText(legend, f"changed significantly ({cm.confidence:.0%}): {cm.n_significant} of "
                f"{int(cm.table['valid'].sum())} cells", (x0 + 24, 55), _FONT, _SMALL, _INK, 1, cv2.LINE_AA)
    _swatch(legend, x0 + 330, 44, mid, FADED, False)
    cv2.putText(legend, "within the level of detection", (x0 + 354, 55), _FONT, _SMALL, _INK, 1, cv2.LINE_AA)
    coverage = cm.coverage()
    _swatch(legend, x0, 66, APPEARED, 0.6, False)
    cv2.putText(legend, f"appeared (only B covers it): {coverage['appeared']} cells", (x0 + 24, 77), _FONT, _SMALL,
                _INK, 1, cv2.LINE_AA)
    _swatch(legend, x0 + 330, 66, VANISHED, 0.6, False)
    cv2.putText(legend, f"vanished (only A covers it): {coverage['vanished']} cells", (x0 + 354, 77), _FONT,
                _SMALL, _INK, 1, cv2.LINE_AA)
    _swatch(legend, x0, 88, _NODATA, 1.0, False)
    cv2.putText(legend, f"too few points (< {counted(cm.min_points, 'defined point')}): {coverage['too few points']}",
                (x0 + 24, 99), _FONT, _SMALL, _INK, 1, cv2.LINE_AA)
    cv2.putText(legend, "numbers: most changed first", (x0 + 330, 99), _FONT, _SMALL, _INK, 1, cv2.LINE_AA)
    return legend


def _when_legend(series):
    import cv2

    n = len(series.maps)
    width = 620
    legend = np.full((26 + 22 * (n + 1), width, 3), 255, np.uint8)
    cv2.putText(legend, "when: the interval in which the cell changed most (significant cells)", (12, 16), _FONT,
                _SMALL, _INK, 1, cv2.LINE_AA)
    when = series.when()
    for k in range(n):
        y = 26 + 22 * k
        _swatch(legend, 12, y, tuple(INTERVALS[k % len(INTERVALS)]), ALPHA, True)
        cv2.putText(legend, f"{series.interval_name(k)}: {int((when == k + 1).sum())} cells", (36, y + 11), _FONT,
                    _SMALL, _INK, 1, cv2.LINE_AA)
    y = 26 + 22 * n
    _swatch(legend, 12, y, (255, 255, 255), FADED, False)
    cv2.putText(legend, f"compared, never significant: {int((when == 0).sum())} cells; grey: not compared",
                (36, y + 11), _FONT, _SMALL, _INK, 1, cv2.LINE_AA)
    return legend
