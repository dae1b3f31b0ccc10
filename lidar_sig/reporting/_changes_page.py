"""The HTML report of a change map: the settings and the level of detection, the map over both
epochs, the table of the most changed cells (significant ones marked) with their class
composition, and their signatures side by side."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..base.errors import counted
from ..base.progress import step
from ..method.scales import recorded_scales
from . import _page as page
from ._document import Report
from .map_image import TOP, change_map_image
from .sections import made_line, warnings_list


def changes_report(change_map, *, top=TOP):
    """The :class:`Report` of a computed :class:`lidar_sig.change_map.ChangeMap`: the map over
    both epochs, the most changed cells with their class composition and their signatures side
    by side."""
    from .render import encode_png, signature_image

    cm = change_map
    names = [Path(e.name).name for e in (cm.a, cm.b)]
    pngs = {}
    with step("rendering the report", cells=int(cm.table["valid"].sum())):
        pngs["map.png"] = encode_png(change_map_image(cm, top=top))
        scale = max(1, 256 // cm.frame.size)
        for rank, c in enumerate(cm.ranked(top), 1):
            for tag, sig in zip("ab", cm.signatures(int(c))):
                pngs[f"cell{rank}_{tag}.png"] = encode_png(signature_image(sig, "sas", cm.render, scale=scale))
    title = f"lidar_sig change map: {names[0]} and {names[1]}"
    summary = (f"<ul><li><span class=\"a\">A</span> <code>{page.esc(cm.a.name)}</code> "
               f"({counted(cm.a.n_points, 'point')})</li><li><span class=\"b\">B</span> "
               f"<code>{page.esc(cm.b.name)}</code> "
               f"({counted(cm.b.n_points, 'point')})</li></ul>" + settings_text(cm))
    maps = page.image(pngs["map.png"], "change map", caption="Each cell in its colour on the change scale (the "
                      "same classes on every map, in QGIS and in the notebook): how far it lies from its level of "
                      "detection; the cells not compared by their state; the most changed numbered by rank.")
    cells = []
    for rank in range(1, min(top, int(cm.table["valid"].sum())) + 1):
        cells.append(page.image(pngs[f"cell{rank}_a.png"], f"Sas of A in cell {rank}",
                                caption=f'<span class="a">A</span>, cell {rank}'))
        cells.append(page.image(pngs[f"cell{rank}_b.png"], f"Sas of B in cell {rank}",
                                caption=f'<span class="b">B</span>, cell {rank}'))
    parts = [summary,
             page.section("Warnings", warnings_list(cm.warnings), anchor="warnings"),
             page.section("Map", maps, anchor="map"),
             page.section("Most changed cells", cells_table(cm, top), anchor="top"),
             page.section("Level of detection", levels_table(cm), anchor="lod"),
             page.section("Signatures of the most changed cells",
                          "<p>Sas of each cell in A (left) and B (right): each point placed in the triangle by "
                          "its saliency, coloured by its class.</p>",
                          '<div class="grid">' + "".join(cells) + "</div>", anchor="signatures")]
    return Report(title, page.fragment(title, made_line(), parts), pngs)


def settings_text(cm):
    """The grid, the rules that chose it, the ranking and how many cells changed significantly."""
    valid = int(cm.table["valid"].sum())
    chosen = {"auto": "chosen from the epochs' densities", "given": "given"}
    density = " and ".join(f"{d:.3g}" for d in cm.density) + " points/m²"
    density += "".join(f"; {text}" for text in [cm.sample_text()] if text)  # the cells' sample, if any
    crs = cm.settings()["crs"] or "the coordinates (no CRS)"
    ranking = cm.score_name
    return (f"<p>Cells of {cm.cell:g} m ({cm.grid.rows} x {cm.grid.cols}, aligned to multiples of the cell size in "
            f"{page.esc(crs)}; {chosen[cm.cell_rule]}); {valid} of {cm.grid.n_cells} cells hold {cm.min_points:,} "
            f"points with defined saliency or more in both epochs ({chosen[cm.min_points_rule]}; densities "
            f"{density}) and are compared. Ranked by <b>{page.esc(ranking)}</b>: "
            f"<b>{cm.n_significant} of {valid} cells changed significantly</b> (their score or their height "
            f"component exceeds its level of detection, at {cm.confidence:.0%} confidence together), listed "
            f"first, each by how far it lies from its level of detection (lod_ratio, the map's colour); per-cell "
            f"signatures in a {cm.frame.size} px frame, {page.esc(cm.render)} rendering; saliency "
            f"{page.esc(_method(cm.method))}, "
            "computed on each whole epoch.</p>" + coverage_text(cm))


def coverage_text(cm):
    """The cells by coverage state, and those that only one epoch covers with their bounds."""
    counts = cm.coverage()
    text = ("<p>Coverage: " + ", ".join(f"{n} {page.esc(state)}" for state, n in counts.items())
            + " (appeared: only B covers the cell; vanished: only A; too few points: points of either or both, "
            f"fewer than {cm.min_points:,} with defined saliency in one of them; not covered: no point).</p>")
    text += "".join(f"<p>{page.esc(line[:1].upper() + line[1:])}.</p>" for line in cm.answer())
    rows = [[page.esc(state), f"{c['bounds'][0]:.0f} to {c['bounds'][2]:.0f}<br>{c['bounds'][1]:.0f} to "
             f"{c['bounds'][3]:.0f}", f"{c['points_a']:,} / {c['points_b']:,}",
             "yes" if c["changed"] else "no: an edge or a gap"]
            for state in ("appeared", "vanished") for c in cm.uncompared(state)]
    if rows:
        text += page.table(("coverage", "cell x, y", "points A / B", "changed"), rows, numeric=(2,))
    return text


def cells_table(cm, top):
    """The most changed cells: rank (* significant), bounds, points, score and its level of
    detection, delta_H and its level, z, other metrics, classes before and after."""
    from ..metrics import METRIC_KEYS

    names = cm.names

    rows = []
    for item in cm.top(top):
        x0, y0, x1, y1 = item["bounds"]
        composition = "<br>".join(f"{page.esc(k)}: {a:,} &rarr; {b:,}" for k, (a, b) in item["classes"].items())
        lod = "" if item["lod"] is None else f"{item['lod']:.4f}"
        also = ", ".join(names[k] for k in item["significant_metrics"]) or "none"
        rows.append([f"{item['rank']}{' *' if item['significant'] else ''}", f"{x0:.0f} to {x1:.0f}<br>{y0:.0f} to "
                     f"{y1:.0f}", f"{item['points_a']:,} / {item['points_b']:,}", f"{item['score']:.4f}", lod,
                     f"{item['height']:.2f} / " + ("" if item["height_lod"] is None else f"{item['height_lod']:.2f}"),
                     "" if item["z"] is None else f"{item['z']:.1f}",
                     "<br>".join(f"{names[k]} {item[k]:.3f}" for k in METRIC_KEYS
                                 if k != cm.score and item.get(k) is not None) + f"<br>significant in: {page.esc(also)}", composition])
    height = cm.names[cm.tests[1]]
    note = ("<p>* changed significantly: the score or the height component delta_H exceeds its level of "
            "detection, the value unchanged land would reach between these two epochs (sampled as this cell is, "
            f"surveyed as these two surveys differ everywhere), the two tests together at {cm.confidence:.0%}. "
            "Significant cells first, then by how far the cell lies from its level of detection (lod_ratio: the "
            "larger of score / lod and delta_H / its level), the quantity the map is coloured by.</p>")
    return note + page.table(("rank", "cell x, y", "points A / B", "score", "level of detection",
                              f"{height} / level (m)", "z", "other metrics", "classes A &rarr; B"), rows,
                             numeric=(0, 2, 3, 4, 5, 6))


def levels_table(cm):
    """Per metric: the survey part of the level of detection and the cells significant in it."""
    names = cm.names

    rows = []
    for key, level in cm.levels.items():
        if not np.isfinite(level.mu0).any():
            continue  # undefined (delta_KL and L1 of unlabelled epochs)
        rows.append([page.esc(names[key]), f"{np.exp(level.beta):.3g}", f"{level.tau:.3f}",
                     f"{int(level.significant.sum())}"])
    return ("<p>For each cell and metric, resamples of each epoch's points give the score of unchanged land "
            "sampled as the cell is; over all cells, the median ratio of the score to it (the survey factor) is "
            "what differs between the two surveys everywhere (density, noise, sensor, classification), its robust "
            "spread how much that varies from cell to cell. A change covering most cells reads as a survey "
            "difference; docs/changes.md says what else the level cannot see.</p>"
            + page.table(("metric", "survey factor exp(beta)", "spread tau (log)", "significant cells"), rows,
                         numeric=(1, 2, 3)))


def _method(m):
    scales = recorded_scales(m)
    shown = scales.describe() if scales is not None else "scales ?"
    return f"{m.get('descriptor', '?')} {m.get('strategy', '?')}, {shown}, {m.get('weights', '?')} weights"
