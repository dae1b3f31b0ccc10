"""Tiles unlike their neighbours and the survey: a score per tile, highest first, with the classes
that make the difference.

- The distance between two tiles is the **screening distance** (the mean of the metrics that
  come from the tiles' vectors, each divided by its spread over the catalogue;
  :mod:`lidar_sig.survey_catalog._distances`), for all N^2 pairs: the image metrics, computed per
  pair, would take an hour for the 500,000 pairs of 1,000 tiles (docs/performance.md).
- A tile's **spatial neighbours** are the tiles of its CRS whose footprints (convex hulls) touch
  it or lie within ``reach`` metres (default a quarter of the median tile side: the eight
  tiles around a tile of a square grid, not the next ring).
- ``d_neighbours`` is a tile's median distance to its neighbours, ``d_survey`` its median
  distance to every other tile. Each is turned into a robust z-score over the tiles
  ((value - median) / (1.4826 MAD)); the **score** is the mean of the two (the survey's alone for
  a tile without neighbours).
- **The classes that make the difference**: the class shares that differ most from the median
  shares of the tile's neighbours (of the survey without neighbours), in percentage points.
- A tile **stands out** when its score reaches :data:`OUTLIER_SCORE` (3.5), the usual mark of an
  outlier for the modified z-score (Iglewicz and Hoaglin); a survey may have none.
"""
from __future__ import annotations

import os
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from ..base.errors import LidarSigError, positive_metres
from ..base.views import Records, one_line
from ._distances import combine, screening
from ._footprint import neighbours as spatial_neighbours

if TYPE_CHECKING:
    from ..reporting import Report

#: Default reach of spatial neighbours, as a share of the median tile side.
REACH_SHARE = 0.25
#: Classes listed as making the difference, at most, and the least difference listed (points).
CLASSES_LISTED = 3
CLASS_DIFFERENCE_MIN = 1.0
#: The score from which a tile stands out: 3.5, the mark of an outlier that Iglewicz and Hoaglin
#: give for the modified z-score (docs/catalog.md).
OUTLIER_SCORE = 3.5
#: Fewest tiles whose scores the verdict states without reserve: a tile and its eight neighbours
#: of a square grid. Below, the medians and MADs rest on a few distances: the scores are
#: indicative only, and the verdict says so.
FEW_TILES = 9
#: The scores drawn apart by the GeoPackage's style, below OUTLIER_SCORE: the survey's median
#: (0) and a tile worth a look (2).
STYLE_SCORES = (0.0, 2.0)


class OutlierTiles(Records):
    """The tiles :func:`outliers` scored, highest score first, a dict each: a list that prints in
    one line and shows a card."""

    title = "tiles"
    columns = (("rank", lambda r: r["rank"], True), ("tile", lambda r: r["name"], False),
               ("score", lambda r: f"{r['score']:.2f}", True),
               ("z neighbours", lambda r: "-" if r["z_neighbours"] is None else f"{r['z_neighbours']:.2f}", True),
               ("z survey", lambda r: f"{r['z_survey']:.2f}", True),
               ("neighbours", lambda r: len(r["neighbours"]), True),
               ("classes that differ (points of share)",
                lambda r: ", ".join(f"{c['class']} {c['difference']:+.1f}" for c in r["classes"]), False),
               ("stands out", lambda r: "yes" if r["outlier"] else "no", False))

    def summary(self):
        top = ", ".join(f"{r['name']} {r['score']:.2f}" for r in self[:3])
        return f"{len(self)} {self.title}, highest score first: {top}"


@dataclass(repr=False)
class Outliers:
    """The answer of :func:`outliers`: ``results`` (a dict per tile, highest score first), the
    matrix of screening distances ``distances`` (catalogue order), each tile's spatial
    ``neighbours`` (rows), the ``reach`` in metres, the catalogue they come from, and the
    ``threshold`` from which a tile stands out (:data:`OUTLIER_SCORE`)."""

    catalog: object
    results: list
    distances: np.ndarray
    neighbours: list
    reach: float
    metrics: tuple
    notes: list = field(default_factory=list)
    threshold: float = OUTLIER_SCORE

    @property
    def standing_out(self) -> list[dict[str, Any]]:
        """The results whose score reaches :data:`OUTLIER_SCORE`, highest first."""
        return [r for r in self.results if r["outlier"]]

    def verdict(self, marked: str = "") -> str:
        """One line: how many tiles stand out (their names followed by ``marked``, e.g. how the
        command marks them), or that none does; with fewer than :data:`FEW_TILES` tiles, that
        the scores are indicative only."""
        found = self.standing_out
        if not found:
            line = f"no tile stands out: no score reaches {self.threshold:g}, the mark of an outlier"
        else:
            many = len(found) > 1
            line = (f"{len(found)} tile{'s stand' if many else ' stands'} out (score {self.threshold:g} or more, the "
                    f"mark of an outlier): {', '.join(r['name'] for r in found[:3])}{', ...' if len(found) > 3 else ''}"
                    + marked)
        if len(self.results) < FEW_TILES:
            line += (f"; with {len(self.results)} tiles the scores rest on few distances and are indicative "
                     f"({FEW_TILES} or more give them their meaning)")
        return line

    def short_verdict(self) -> str:
        """:meth:`verdict` in a few words, for a line that says more."""
        found, n = self.standing_out, len(self.results)
        said = (f"{len(found)} stand{'s' if len(found) == 1 else ''} out (score {self.threshold:g} or more)" if found
                else f"none stands out (no score reaches {self.threshold:g})")
        return said + (f", indicative with {n} tiles" if n < FEW_TILES else "")

    def __repr__(self):
        top = ", ".join(f"{r['name']} {r['score']:.2f}" for r in self.results[:3])
        return one_line(f"<Outliers of {len(self.results)} tiles within {self.reach:.3g} m: {self.short_verdict()}; "
                        f"highest {top}>")

    def _repr_html_(self):
        """A notebook's view: the verdict, the notes, and the tiles by score."""
        tiles = OutlierTiles(self.results)
        facts = [self.verdict(), f"{len(self.results)} tiles; neighbours within {self.reach:.4g} m; distance: the "
                                 f"screening distance ({', '.join(self.metrics)}, each over its spread)"]
        return tiles.card("Outliers", facts + [f"note: {n}" for n in self.notes],
                          note=f"score: the mean of the robust z of a tile's distance to its neighbours and to the "
                               f"survey; {self.threshold:g} or more stands out")

    def to_dict(self) -> dict[str, Any]:
        """The JSON shape of ``lidar-sig outliers --json``."""
        return {"results": [{k: v for k, v in r.items() if k != "row"} for r in self.results], "reach_m": self.reach, "metrics": list(self.metrics),
                "distance": "screening distance: mean of " + ", ".join(self.metrics) + ", each over its spread",
                "threshold": self.threshold, "standing_out": len(self.standing_out), "verdict": self.verdict(),
                "notes": list(self.notes)}

    def names(self) -> list[str]:
        return [r["name"] for r in self.results]

    def embedding(self) -> np.ndarray:
        """(N, 2) classical MDS of the distance matrix, catalogue order."""
        from ._embedding import classical_mds

        return classical_mds(self.distances)

    def write_geopackage(self, path: str | os.PathLike[str], *, overwrite: bool = False) -> None:
        """The tiles' footprints with every score and metric as a GeoPackage (one layer per CRS),
        with a spatial index and a default style: the tiles that stand out filled red and
        labelled with their rank, the others shaded by score."""
        from ..io.geopackage import tile_layers, write_geopackage

        cat = self.catalog
        layers = {}
        for r in self.results:
            i = r["row"]
            crs = cat.crs_of(i)
            fields = {k: v for k, v in r.items() if k not in ("row", "classes")}
            fields["outlier"] = int(r["outlier"])
            fields["classes"] = "; ".join(f"{c['class']} {c['difference']:+.1f}" for c in r["classes"])
            layers.setdefault(crs, []).append((cat.columns["hull"][i], fields))
        write_geopackage(path, tile_layers(layers, style=tiles_style()), overwrite=overwrite)

    def report(self, *, top: int | None = None) -> Report:
        """The HTML report (:func:`lidar_sig.reporting.outliers_report`)."""
        from ..reporting import outliers_report

        return outliers_report(self, top=top)


def tiles_style():
    """The QGIS style of the tiles' layer (QML): red where a tile stands out (labelled with its
    rank), orange from 2, pale above the survey's median, white below it."""
    from ..io.styles import Rule, polygon_qml

    low, look = STYLE_SCORES
    edge = (90, 90, 90)
    return polygon_qml([
        Rule(f"stands out (score {OUTLIER_SCORE:g} or more)", f'"score" >= {OUTLIER_SCORE!r}', (150, 0, 20), 0.6,
             fill=(227, 26, 28), fill_alpha=170, pattern="solid"),
        Rule(f"worth a look ({look:g} to {OUTLIER_SCORE:g})", f'"score" >= {look!r} AND "score" < {OUTLIER_SCORE!r}',
             edge, fill=(253, 141, 60), fill_alpha=150, pattern="solid"),
        Rule(f"above the survey's median ({low:g} to {look:g})", f'"score" >= {low!r} AND "score" < {look!r}', edge,
             fill=(255, 237, 160), fill_alpha=150, pattern="solid"),
        Rule(f"below the survey's median (under {low:g})", f'"score" < {low!r}', edge, fill=(255, 255, 255),
             fill_alpha=120, pattern="solid"),
    ], label_expression='if("outlier" = 1, \'#\' || "rank", NULL)')


def robust_z(values):
    """(value - median) / (1.4826 MAD) over the finite values (NaN stays NaN); with a MAD of 0,
    the mean absolute deviation (times 1.2533) scales, and with that 0 too, every z is 0."""
    values = np.asarray(values, np.float64)
    ok = np.isfinite(values)
    out = np.full(values.shape, np.nan)
    if not ok.any():
        return out
    v = values[ok]
    centre = np.median(v)
    scale = 1.4826 * np.median(np.abs(v - centre))
    if scale <= 0:
        scale = 1.2533 * np.mean(np.abs(v - centre))
    out[ok] = (v - centre) / scale if scale > 0 else 0.0
    return out


def default_reach(catalog):
    """A quarter of the median tile side (the square root of the median footprint area), metres."""
    area = np.asarray(catalog.columns["area"], np.float64)
    area = area[np.isfinite(area) & (area > 0)]
    return REACH_SHARE * float(np.sqrt(np.median(area))) if len(area) else 0.0


def outliers(catalog, *, reach=None):
    """Score every tile of ``catalog`` (module docstring); ``reach`` in metres (default
    :func:`default_reach`). Returns an :class:`Outliers`, highest score first."""
    n = len(catalog)
    if n < 2:
        raise LidarSigError("the catalogue holds one tile: outliers need at least two", path=catalog.path)
    reach = default_reach(catalog) if reach is None else positive_metres(reach, "reach (of spatial neighbours)")
    values = screening(catalog.features, catalog.features, catalog.labelled)
    keys = tuple(values)
    dist = combine(values, catalog.spread, keys)
    np.fill_diagonal(dist, 0.0)
    c = catalog.columns
    near = [np.empty(0, np.int64)] * n
    crs_groups = np.asarray(c["crs"])
    for g in np.unique(crs_groups):
        rows = np.flatnonzero(crs_groups == g)
        factor = float(c["factors"][rows[0]][0])  # metres per unit in this CRS
        found = spatial_neighbours([c["hull"][i] for i in rows], c["bounds"][rows], reach / factor)
        for i, nb in zip(rows, found):
            near[i] = rows[nb]
    others = ~np.eye(n, dtype=bool)
    d_near = np.array([np.median(dist[i, near[i]]) if len(near[i]) else np.nan for i in range(n)])
    d_all = np.array([np.median(dist[i, others[i]]) for i in range(n)])
    z_near, z_all = robust_z(d_near), robust_z(d_all)
    score = np.where(np.isfinite(z_near), (z_near + z_all) / 2.0, z_all)
    shares = np.asarray(c["class_totals"], np.float64)
    shares = shares / np.maximum(shares.sum(axis=1, keepdims=True), 1.0) * 100.0
    results = []
    for i in np.lexsort((np.arange(n), -score)):
        ref = near[i] if len(near[i]) else np.flatnonzero(others[i])
        per_metric = {k: float(np.median(values[k][i, ref])) for k in keys}
        results.append({"rank": len(results) + 1, "name": c["name"][i], "path": c["path"][i],
                        "score": float(score[i]), "z_neighbours": _num(z_near[i]), "z_survey": float(z_all[i]),
                        "d_neighbours": _num(d_near[i]), "d_survey": float(d_all[i]),
                        "neighbours": [c["name"][j] for j in near[i]], **per_metric,
                        "outlier": bool(score[i] >= OUTLIER_SCORE),
                        "points": int(c["n_points"][i]), "density": float(c["density"][i]),
                        "classes": _differences(catalog.classes.class_names, shares[i], np.median(shares[ref], axis=0)),
                        "row": int(i)})
    notes = []
    if len(np.unique(crs_groups)) > 1:
        notes.append(f"the tiles are in {len(np.unique(crs_groups))} CRSs: neighbours are found within each CRS")
    from ._build import duplicate_note, duplicates

    for kind, group in duplicates(c["sha256"], c["n_points"], c["bounds"], c["class_totals"], catalog.features.fv):
        notes.append(duplicate_note(kind, [c["name"][i] for i in group]))
    alone = sum(1 for nb in near if not len(nb))
    if alone:
        notes.append(f"{alone} tile{'s have' if alone > 1 else ' has'} no neighbour within {reach:.4g} m: "
                     "scored against the survey only")
    return Outliers(catalog, OutlierTiles(results), dist, near, reach, keys, notes)


def _num(value):
    return None if not np.isfinite(value) else float(value)


def _differences(names, share, reference):
    """The classes whose share differs most from the reference's (percentage points)."""
    diff = share - reference
    out = []
    for k in np.argsort(-np.abs(diff), kind="stable")[:CLASSES_LISTED]:
        if abs(diff[k]) >= CLASS_DIFFERENCE_MIN:
            out.append({"class": names[k], "share": float(share[k]), "neighbours": float(reference[k]),
                        "difference": float(diff[k])})
    return out
