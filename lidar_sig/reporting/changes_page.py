"""The HTML report of a change map: the map over both epochs, the table of the most changed
cells with their class composition, and their signatures side by side."""
from __future__ import annotations

from pathlib import Path

from ..progress import step
from . import page
from .document import Report
from .map_image import TOP, change_map_image
from .sections import made_line


def changes_report(change_map, *, top=TOP):
    """The :class:`Report` of a computed :class:`lidar_sig.change_map.ChangeMap`: the map over
    both epochs, the most changed cells with their class composition and their signatures side
    by side."""
    from ..metrics import METRIC_NAMES
    from ..render import encode_png, signature_image

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
    valid = int(cm.table["valid"].sum())
    summary = (f"<ul><li><span class=\"a\">A</span> <code>{page.esc(cm.a.name)}</code> "
               f"({len(cm.a.cloud):,} points)</li><li><span class=\"b\">B</span> <code>{page.esc(cm.b.name)}</code> "
               f"({len(cm.b.cloud):,} points)</li></ul>"
               f"<p>Cells of {cm.cell:g} m ({cm.grid.rows} x {cm.grid.cols}, aligned to multiples of the cell size "
               f"in {page.esc(cm.to_dict(0)['crs'] or 'the coordinates (no CRS)')}); {valid} of {cm.grid.n_cells} "
               f"cells hold {cm.min_points:,} points or more in both epochs and are compared. Ranked by "
               f"<b>{page.esc(METRIC_NAMES[cm.score])}</b>; per-cell signatures in a {cm.frame.size} px frame, "
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
                     "<br>".join(f"{METRIC_NAMES[k]} {item[k]:.3f}" for k in ("bhattacharyya", "emd_info", "fv", "l1")
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
    return Report(title, page.fragment(title, made_line(), parts), pngs)


def _method(m):
    scales = ", ".join(f"{v:g}" for v in m.get("scale_values", []))
    kind = "k" if m.get("scale_kind") == "knn" else "radii"
    return f"{m.get('descriptor', '?')} {m.get('strategy', '?')}, {kind} {scales}, {m.get('weights', '?')} weights"
