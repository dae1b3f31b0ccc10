"""Pictures and the HTML page of a change map (:mod:`lidar_sig.change_map`).

The map colours each compared cell by its score over a grey top view of one epoch (north up),
greys out the cells without data, and numbers the most changed cells; the page shows the map
over both epochs, the table of the most changed cells and their signatures side by side.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..progress import step
from . import page

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

    from ..metrics import METRICS
    from ..render import ramp

    width = max(width, 420)
    legend = np.full((74, width, 3), 255, np.uint8)
    x0, x1 = 12, width // 2
    legend[10:24, x0:x1] = ramp(np.linspace(0.0, 1.0, x1 - x0), SEQUENTIAL)[None]
    cv2.rectangle(legend, (x0, 10), (x1 - 1, 23), (90, 90, 90), 1)
    name = {m.key: m.name for m in METRICS}[cm.score]
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


def changes_report(change_map, *, top=TOP):
    """The :class:`lidar_sig.reporting.Report` of a change map: the map over both epochs, the
    most changed cells with their class composition and their signatures side by side."""
    from ..metrics import METRICS
    from ..render import encode_png, signature_image
    from . import Report, _made

    cm = change_map
    names = [Path(e.name).name for e in (cm.a, cm.b)]
    pngs = {}
    with step("rendering the report", cells=int(cm.table["valid"].sum())):
        pngs["map_a.png"] = encode_png(change_map_image(cm, "a", top=top))
        pngs["map_b.png"] = encode_png(change_map_image(cm, "b", top=top))
        scale = max(1, 256 // cm.frame.size)
        for rank, c in enumerate(cm.ranked(top), 1):
            for tag, sig in zip("ab", cm.signatures(int(c))):
                pngs[f"cell{rank}_{tag}.png"] = encode_png(signature_image(sig, "sas", cm.render, scale=scale))
    title = f"lidar_sig change map: {names[0]} and {names[1]}"
    metric_name = {m.key: m.name for m in METRICS}
    valid = int(cm.table["valid"].sum())
    summary = (f"<ul><li><span class=\"a\">A</span> <code>{page.esc(cm.a.name)}</code> "
               f"({len(cm.a.cloud):,} points)</li><li><span class=\"b\">B</span> <code>{page.esc(cm.b.name)}</code> "
               f"({len(cm.b.cloud):,} points)</li></ul>"
               f"<p>Cells of {cm.cell:g} m ({cm.grid.rows} x {cm.grid.cols}, aligned to multiples of the cell size "
               f"in {page.esc(cm.to_dict(0)['crs'] or 'the coordinates (no CRS)')}); {valid} of {cm.grid.n_cells} "
               f"cells hold {cm.min_points:,} points or more in both epochs and are compared. Ranked by "
               f"<b>{page.esc(metric_name[cm.score])}</b>; per-cell signatures in a {cm.frame.size} px frame, "
               f"{page.esc(cm.render)} rendering; saliency {page.esc(_method(cm.method))}, computed on each whole "
               "epoch.</p>")
    maps = ('<div class="grid">'
            + page.image(pngs["map_a.png"], "change map over A", caption=f"Score over a top view of A, "
                         f"<code>{page.esc(names[0])}</code>")
            + page.image(pngs["map_b.png"], "change map over B", caption=f"Score over a top view of B, "
                         f"<code>{page.esc(names[1])}</code>")
            + "</div>")
    rows = []
    for item in cm.top(top):
        x0, y0, x1, y1 = item["bounds"]
        composition = "<br>".join(f"{page.esc(k)}: {a:,} &rarr; {b:,}" for k, (a, b) in item["classes"].items())
        rows.append([str(item["rank"]), f"{x0:.0f} to {x1:.0f}<br>{y0:.0f} to {y1:.0f}",
                     f"{item['points_a']:,} / {item['points_b']:,}", f"{item['score']:.4f}",
                     "<br>".join(f"{metric_name[k]} {item[k]:.3f}" for k in ("bhattacharyya", "emd_info", "fv", "l1")
                                 if item[k] is not None), composition])
    table = page.table(("rank", "cell x, y", "points A / B", "score", "other metrics", "classes A &rarr; B"),
                       rows, numeric=(0, 2, 3))
    cells = []
    for rank in range(1, len(rows) + 1):
        cells.append(page.image(pngs[f"cell{rank}_a.png"], f"Sas of A in cell {rank}",
                                caption=f'<span class="a">A</span>, cell {rank}'))
        cells.append(page.image(pngs[f"cell{rank}_b.png"], f"Sas of B in cell {rank}",
                                caption=f'<span class="b">B</span>, cell {rank}'))
    parts = [summary,
             page.section("Map", maps, anchor="map"),
             page.section("Most changed cells", table, anchor="top"),
             page.section("Signatures of the most changed cells",
                          "<p>Sas of each cell in A (left) and B (right): each point placed in the triangle by "
                          "its saliency, coloured by its class.</p>",
                          '<div class="grid">' + "".join(cells) + "</div>", anchor="signatures")]
    return Report(title, page.fragment(title, _made(), parts), pngs)


def _method(m):
    scales = ", ".join(f"{v:g}" for v in m.get("scale_values", []))
    kind = "k" if m.get("scale_kind") == "knn" else "radii"
    return f"{m.get('descriptor', '?')} {m.get('strategy', '?')}, {kind} {scales}, {m.get('weights', '?')} weights"
