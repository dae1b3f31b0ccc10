"""The picture of a change map (:mod:`lidar_sig.change_map`): each compared cell coloured by its
score over a grey top view of one epoch (north up), the cells without data greyed out, the most
changed cells numbered, and a legend below.
"""
from __future__ import annotations

import numpy as np

#: ColorBrewer YlOrRd, light (no change) to dark red (most change), for the score.
SEQUENTIAL = np.array([(255, 255, 204), (255, 237, 160), (254, 217, 118), (254, 178, 76), (253, 141, 60),
                       (252, 78, 42), (227, 26, 28), (189, 0, 38), (128, 0, 38)], dtype=np.float64)
#: Opacity of the score colours over the top view.
ALPHA = 0.6
#: Cells numbered on the map and shown in the report.
TOP = 5
_INK = (20, 20, 20)
_NODATA = (170, 170, 170)


def change_map_image(change_map, epoch="b", *, display=640, top=TOP):
    """(H, W, 3) uint8 map of the score per cell over a grey top view of epoch ``"a"`` or
    ``"b"``, the ``top`` most changed cells numbered, with a legend below."""
    import cv2

    from ..render import ramp, top_view

    cm = change_map
    e = cm.a if epoch == "a" else cm.b
    g = cm.grid
    view, px = top_view(e.cloud.xyz, e.saliency.values)
    grey = cv2.cvtColor(view, cv2.COLOR_RGB2GRAY)
    grey = (255 - 0.55 * (255 - grey.astype(np.float64))).astype(np.uint8)  # a light backdrop
    # place the top view in the grid's extent (it starts at the epoch's own lower-left point)
    width, height = g.cols * g.size, g.rows * g.size
    factor = display / max(width, height)  # display px per CRS unit
    size = (max(1, round(width * factor)), max(1, round(height * factor)))
    canvas = np.full((size[1], size[0]), 255, np.uint8)
    lo = e.cloud.xyz[:, :2].min(axis=0)
    hi_y = e.cloud.xyz[:, 1].max()
    scaled = cv2.resize(grey, (max(1, round(view.shape[1] * px * factor)), max(1, round(view.shape[0] * px * factor))),
                        interpolation=cv2.INTER_AREA)
    x_off, y_off = round((lo[0] - g.x0) * factor), round((g.y0 + height - hi_y) * factor)
    h, w = min(scaled.shape[0], canvas.shape[0] - y_off), min(scaled.shape[1], canvas.shape[1] - x_off)
    canvas[y_off:y_off + h, x_off:x_off + w] = scaled[:h, :w]
    rgb = np.repeat(canvas[..., None], 3, axis=2).astype(np.float64)
    score = cm.table["score"]
    valid = cm.table["valid"]
    top_value = float(np.nanmax(score[valid])) if valid.any() else 1.0
    colours = ramp(np.nan_to_num(score / (top_value or 1.0)), SEQUENTIAL).astype(np.float64)
    edges = np.rint(np.arange(g.cols + 1) * g.size * factor).astype(int), \
        np.rint(np.arange(g.rows + 1) * g.size * factor).astype(int)
    for c in range(g.n_cells):
        r, k = divmod(c, g.cols)
        ys, xs = slice(edges[1][r], edges[1][r + 1]), slice(edges[0][k], edges[0][k + 1])
        if valid[c]:
            rgb[ys, xs] = (1 - ALPHA) * rgb[ys, xs] + ALPHA * colours[c]
        elif cm.table["points_a"][c] or cm.table["points_b"][c]:
            rgb[ys, xs] = 0.5 * rgb[ys, xs] + 0.5 * np.asarray(_NODATA)
    rgb = np.rint(rgb).astype(np.uint8)
    for x in edges[0]:
        cv2.line(rgb, (min(x, size[0] - 1), 0), (min(x, size[0] - 1), size[1] - 1), (110, 110, 110), 1)
    for y in edges[1]:
        cv2.line(rgb, (0, min(y, size[1] - 1)), (size[0] - 1, min(y, size[1] - 1)), (110, 110, 110), 1)
    font = 0.5
    for rank, c in enumerate(cm.ranked(top), 1):
        r, k = divmod(int(c), g.cols)
        text = str(rank)
        (tw, th), _ = cv2.getTextSize(text, 0, font, 2)
        org = ((edges[0][k] + edges[0][k + 1] - tw) // 2, (edges[1][r] + edges[1][r + 1] + th) // 2)
        cv2.putText(rgb, text, org, 0, font, (255, 255, 255), 4, cv2.LINE_AA)
        cv2.putText(rgb, text, org, 0, font, _INK, 2, cv2.LINE_AA)
    return np.vstack([rgb, _legend(size[0], top_value, cm)])


def _legend(width, top_value, cm):
    import cv2

    from ..metrics import METRIC_NAMES
    from ..render import ramp

    width = max(width, 420)
    legend = np.full((74, width, 3), 255, np.uint8)
    x0, x1 = 12, width // 2
    legend[10:24, x0:x1] = ramp(np.linspace(0.0, 1.0, x1 - x0), SEQUENTIAL)[None]
    cv2.rectangle(legend, (x0, 10), (x1 - 1, 23), (90, 90, 90), 1)
    name = METRIC_NAMES[cm.score]
    font = 0.42
    cv2.putText(legend, "0", (x0, 40), 0, font, _INK, 1, cv2.LINE_AA)
    text = f"{top_value:.3g}"
    (tw, _), _ = cv2.getTextSize(text, 0, font, 1)
    cv2.putText(legend, text, (x1 - tw, 40), 0, font, _INK, 1, cv2.LINE_AA)
    cv2.putText(legend, f"score {name} per {cm.cell:g} m cell; numbers: most changed", (x0, 60), 0, font,
                _INK, 1, cv2.LINE_AA)
    cv2.rectangle(legend, (x1 + 16, 10), (x1 + 30, 23), _NODATA, -1)
    cv2.putText(legend, f"no data (< {cm.min_points:,} points)", (x1 + 36, 22), 0, font, _INK, 1, cv2.LINE_AA)
    cv2.putText(legend, "north up", (x1 + 16, 40), 0, font, _INK, 1, cv2.LINE_AA)
    return legend
