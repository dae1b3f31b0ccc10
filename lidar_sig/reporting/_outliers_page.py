"""The HTML report of a catalogue's outliers, what a quality-control reviewer opens: which tiles
stand out (a score of 3.5 or more) or that none does, the table of the tiles by score with the
classes that make the difference, a map of the footprints coloured
by score, the signatures (Sas) of the top outliers beside their neighbours', the tiles placed by
likeness (classical MDS of the distances), and the method and catalogue."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..base.errors import counted
from ..base.progress import step
from . import _page as page
from ._document import Report
from .sections import class_legend, made_line, scales_text

#: Top outliers whose signatures are shown beside their neighbours', neighbours shown each, rows
#: of the table.
TOP_SHOWN = 3
NEIGHBOURS_SHOWN = 3
TABLE_ROWS = 25


def outliers_report(outliers, *, top=None):
    """The :class:`Report` of computed :class:`lidar_sig.survey_catalog._outlier_scores.Outliers`; ``top``
    outliers (default TOP_SHOWN) are shown beside their neighbours."""
    from ..method.crs import crs_name
    from ..metrics import METRIC_NAMES

    o = outliers
    cat = o.catalog
    top = TOP_SHOWN if top is None else max(1, int(top))
    shown = o.results[:min(top, len(o.results))]
    pngs, groups, signatures, shown_near = _pictures(o, shown)
    title = f"lidar_sig outliers: {Path(str(cat.path)).name}"
    maps = "".join(page.image(pngs[f"map_{g}.png"], f"map of outlier scores ({crs_name(cat.header['crs'][g]) or 'no CRS'})",
                              caption="Tile footprints (convex hulls of their points) coloured by score; "
                                      "the top outliers are numbered.") for g in groups)
    spread_rows = [[page.esc(METRIC_NAMES[k]), f"{v:.4g}"] for k, v in cat.spread.items()]
    crs_rows = [[page.esc(crs_name(w) or "none recorded"), f"{int(np.sum(np.asarray(cat.columns['crs']) == g)):,}"]
                for g, w in enumerate(cat.header["crs"])]
    parts = [
        _summary(o),
        page.section("Tiles by score", *_scores_table(o), anchor="outliers"),
        page.section("Map", maps, anchor="map"),
        page.section("Top outliers beside their neighbours" if o.standing_out else
                     "Highest scores beside their neighbours (no tile stands out)",
                     "<p>Sas of each of the highest-scoring tiles (left) and of its nearest neighbours in signature: "
                     "each point placed in the triangle by its saliency, coloured by its class.</p>",
                     class_legend(signatures),
                     *_beside(o, shown, shown_near, pngs), anchor="signatures"),
        page.section("Tiles by likeness",
                     page.image(pngs["likeness.png"], "tiles placed by likeness (classical MDS)",
                                caption="Classical multidimensional scaling of the screening distances: tiles close "
                                        "in this plane have similar signatures; outliers stand apart."),
                     anchor="likeness"),
        page.section("Method and catalogue",
                     page.table(("metric", "spread over the catalogue"), spread_rows, numeric=(1,)),
                     page.table(("CRS", "tiles"), crs_rows, numeric=(1,)), anchor="provenance"),
    ]
    return Report(title, page.fragment(title, made_line(), parts), pngs)


def _pictures(o, shown):
    """The report's pictures by file name (a footprint map per CRS, the tiles by likeness, Sas of
    each ``shown`` outlier and of its nearest neighbours), the CRS groups, the signatures shown
    and each outlier's neighbours shown (by rank)."""
    from . import _figures as figures
    from . import render as images
    from ..method.crs import crs_name

    cat = o.catalog
    score = np.empty(len(cat))
    for r in o.results:
        score[r["row"]] = r["score"]
    labels = [None] * len(cat)
    for r in shown:
        labels[r["row"]] = f"#{r['rank']}"
    pngs = {}
    signatures = []
    shown_near = {}
    with step("rendering the report", tiles=len(cat)):
        groups = sorted(set(np.asarray(cat.columns["crs"]).tolist()))
        for g in groups:
            rows = [i for i in range(len(cat)) if int(cat.columns["crs"][i]) == g]
            name = crs_name(cat.header["crs"][g]) or "no CRS"
            pngs[f"map_{g}.png"] = figures.footprint_map([cat.columns["hull"][i] for i in rows], score[rows],
                                                         [labels[i] for i in rows], title=name)
        pngs["likeness.png"] = figures.likeness_map(o.embedding(), score, labels)
        for r in shown:
            i = r["row"]
            near = o.neighbours[i]
            near = near[np.argsort(o.distances[i, near], kind="stable")][:NEIGHBOURS_SHOWN] if len(near) else \
                np.argsort(o.distances[i], kind="stable")[1:NEIGHBOURS_SHOWN + 1]
            for tag, j in [("", i)] + [(f"_n{k + 1}", int(j)) for k, j in enumerate(near)]:
                sig = cat.signature(int(j))
                signatures.append(sig)
                pngs[f"outlier{r['rank']}{tag}.png"] = images.encode_png(images.signature_image(sig, "sas"))
            shown_near[r["rank"]] = [int(j) for j in near]
    return pngs, groups, signatures, shown_near


def _summary(o):
    """The catalogue, the method, how tiles are scored and the verdict; the notes."""
    from ..metrics import METRIC_NAMES

    cat = o.catalog
    method = cat.method
    summary = (f"<p>Catalogue <code>{page.esc(cat.path)}</code>: {counted(len(cat), 'tile')}; signatures "
               f"{page.esc(method.get('descriptor', '?'))} {page.esc(method.get('strategy', '?'))}, "
               f"{page.esc(scales_text(method))}, {page.esc(method.get('weights', '?'))} weights, each tile's "
               "saliency computed on the tile alone.</p>"
               "<p>Each tile is scored by how unlike it is to its spatial neighbours (footprints touching it or "
               f"within {o.reach:.3g} m) and to the survey as a whole: the <b>score</b> is the mean of the "
               "robust z-scores of its median distance to its neighbours and to every tile. The distance is the "
               "screening distance, the mean of " + ", ".join(page.esc(METRIC_NAMES[k]) for k in o.metrics)
               + ", each divided by its spread over the catalogue. A tile <b>stands out</b> when its score "
               f"reaches {o.threshold:g}, the usual mark of an outlier for robust z-scores.</p>"
               f'<p class="{"warnings" if o.standing_out else "ok"}"><b>{page.esc(o.verdict()[:1].upper() + o.verdict()[1:])}.'
               "</b></p>")
    if o.notes:
        summary += '<div class="warnings"><ul>' + "".join(f"<li>{page.esc(n)}</li>" for n in o.notes) + "</ul></div>"
    return summary


def _scores_table(o):
    """The table of the first TABLE_ROWS tiles by score, and a line saying where the others are."""
    rows = []
    for r in o.results[:TABLE_ROWS]:
        classes = "<br>".join(f"{page.esc(c['class'])} {c['share']:.1f}% (neighbours {c['neighbours']:.1f}%)"
                              for c in r["classes"]) or "&ndash;"
        z_near = "&ndash;" if r["z_neighbours"] is None else f"{r['z_neighbours']:.2f}"
        score = f"<b>{r['score']:.2f}</b> (stands out)" if r["outlier"] else f"{r['score']:.2f}"
        rows.append([str(r["rank"]), f"<code>{page.esc(r['name'])}</code>", score, z_near,
                     f"{r['z_survey']:.2f}", str(len(r["neighbours"])), f"{r['points']:,}", f"{r['density']:.1f}",
                     classes])
    table = page.table(("rank", "tile", "score", "z neighbours", "z survey", "neighbours", "points",
                        "points/m&sup2;", "classes that make the difference"), rows, numeric=(0, 2, 3, 4, 5, 6, 7),
                       cls="outliers")
    more = (f'<p class="muted">The {counted(len(o.results) - TABLE_ROWS, "other tile")} are in the JSON and the '
            "GeoPackage outputs.</p>" if len(o.results) > TABLE_ROWS else "")
    return table, more


def _beside(o, shown, shown_near, pngs):
    """A row of pictures per ``shown`` outlier: its Sas, then its neighbours'."""
    cat = o.catalog
    beside = []
    for r in shown:
        cells = [page.image(pngs[f"outlier{r['rank']}.png"], f"Sas of outlier {r['rank']}",
                            caption=f"<b>#{r['rank']}</b> <code>{page.esc(r['name'])}</code>, score {r['score']:.2f}")]
        for k, j in enumerate(shown_near[r["rank"]]):
            cells.append(page.image(pngs[f"outlier{r['rank']}_n{k + 1}.png"], f"Sas of a neighbour of outlier {r['rank']}",
                                    caption=f"neighbour <code>{page.esc(cat.columns['name'][j])}</code>, distance "
                                            f"{o.distances[r['row'], j]:.2f}"))
        beside.append('<div class="grid" style="grid-template-columns: repeat(4, minmax(0, 1fr))">'
                      + "".join(cells) + "</div>")
    return beside
