"""The tiles of a catalogue most like a query, best first, with every metric's value.

1. **Screening**: the screening metrics between the query and every tile, from the tiles'
   vectors (:func:`lidar_sig.survey_catalog._distances.screening`): a few array operations for N tiles.
2. **Shortlist**: the ``max(SHORTLIST_FACTOR * top, SHORTLIST_MIN)`` tiles nearest by the
   screening distance (by the chosen metric itself when it is a screening metric).
3. **Full metrics** for the shortlist, by the metrics' own functions (s_SSIM needs each tile's
   Sg, made from its counts: the costly step, on threads over the cores), then the ranking.

The ranking distance is the mean of every metric (those registered,
:data:`lidar_sig.metrics.METRICS`) each divided by its spread; the screening distance is the same
mean over the screening metrics, so a tile's distance is at least S/M of its screening distance
for S screening metrics of M (5/7 with lidar_sig's own; the image metrics are never negative as
distances). When the first tile left out of the shortlist has S/M of its screening distance at or
above the ``top``-th distance found, no tile outside could enter the top: the answer says it is
``certain``. Ranking by one screening metric is always certain.

A query that is a tile of the catalogue is left out of the answer: the answer is the tiles most
like it among the others (a copy of the tile, e.g. its COPC version, comes first at distance 0).
"""
from __future__ import annotations

import os
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..base.errors import LidarSigError, arg, whole_number
from ..metrics import METRIC_NAMES
from ..base.views import Records, one_line, short_name
from ._distances import IMAGE, SCREENING, as_distance, combine, pair_metrics, screening
from ._features import sg_image

#: The shortlist holds this many times the tiles asked for ...
SHORTLIST_FACTOR = 4
#: ... and at least this many.
SHORTLIST_MIN = 20


class SimilarTiles(Records):
    """The tiles :func:`similar` found, best first, a dict each (rank, name, path, distance and
    every metric): a list that prints in one line and shows a card."""

    title = "tiles"

    @property
    def columns(self):
        keys = [k for k in self.facts.get("keys", ()) if not self or k in self[0]]
        return (("rank", lambda r: r["rank"], True), ("tile", lambda r: r["name"], False),
                ("distance", lambda r: f"{r['distance']:.3f}", True),
                *((METRIC_NAMES[key], lambda r, key=key: _value(r[key]), True) for key in keys))

    def summary(self):
        best = ", ".join(f"{r['name']} {r['distance']:.3g}" for r in self[:3])
        return f"{len(self)} {self.title} by {self.facts.get('metric', 'distance')}, best first: {best}"


def _value(value):
    return "n/a" if value is None else f"{value:.4f}"


@dataclass(repr=False)
class Similar:
    """The answer of :func:`similar`: the query, the metric ranked by, the tiles best first
    (``results``: dicts with rank, name, path, distance and every metric), and how the
    shortlist was made."""

    query: dict
    metric: str
    results: list
    shortlist: dict
    spread: dict = field(default_factory=dict)
    #: The catalogue searched and the row of each tile found, for their footprints.
    catalog: Any = None
    rows: list = field(default_factory=list)

    def __repr__(self):
        best = ", ".join(f"{r['name']} {r['distance']:.3g}" for r in self.results[:3])
        return one_line(f"<Similar to {short_name(self.query.get('name'))}: {len(self.results)} tiles by {self.metric}; {best}>")

    def _repr_html_(self):
        """A notebook's view: the query, how the tiles were found, and the tiles with every metric."""
        tiles = SimilarTiles(self.results, metric=self.metric, keys=tuple(self.spread))
        sure = ("certain: no tile outside the shortlist could enter it" if self.shortlist.get("certain")
                else "not certain: a tile outside the shortlist might enter it (give shortlist= to widen it)")
        facts = [f"query: {self.query.get('kind', '')} {self.query.get('name')}"
                 + (" (a tile of the catalogue, left out of the answer)" if self.query.get("tile") else ""),
                 f"ranked by {self.metric}; every metric computed for {self.shortlist.get('screened_by', '?')}",
                 sure]
        return tiles.card("Similar", facts, note="distance: the mean of the metrics, each over its spread in the "
                                                 "catalogue (0: alike)")

    def to_dict(self) -> dict[str, Any]:
        """The JSON shape of ``lidar-sig similar --json``."""
        return {"results": [dict(r) for r in self.results], "query": dict(self.query), "metric": self.metric,
                "shortlist": dict(self.shortlist), "spread": dict(self.spread)}

    def names(self) -> list[str]:
        return [r["name"] for r in self.results]

    def write_geopackage(self, path: str | os.PathLike[str], *, overwrite: bool = False) -> None:
        """The tiles found as their footprints (convex hulls) with rank, name, path, distance and
        every metric, in a GeoPackage (one layer per CRS) with a spatial index and a default
        style: each tile outlined, labelled with its rank, the metrics by their names."""
        from ..io.geopackage import tile_layers, write_geopackage
        from ..metrics import METRIC

        layers: dict = {}
        for r, i in zip(self.results, self.rows):
            layers.setdefault(self.catalog.crs_of(i), []).append((self.catalog.columns["hull"][i], dict(r)))
        aliases = {k: METRIC[k].name for k in self.spread if k in METRIC}
        style = similar_style(aliases)
        write_geopackage(path, tile_layers(layers, description=f"tiles most like {self.query.get('name')}, best first",
                                           style=style), overwrite=overwrite)


def similar_style(aliases):
    """The QGIS style of the similar tiles' footprints (QML): each tile outlined dark blue,
    labelled with its rank, the metrics shown by their names (``aliases``) with 4 decimals."""
    from ..io.styles import Rule, polygon_qml

    return polygon_qml([Rule("tile like the query (its rank)", "TRUE", (8, 48, 107), 0.6, fill=(158, 202, 225),
                             fill_alpha=90, pattern="solid")],
                       label_expression='"rank"', aliases=aliases,
                       precision={"distance": 4, **{k: 4 for k in aliases}})


def shortlist_size(top, n):
    """How many tiles get the full metrics when ``top`` are asked of ``n``."""
    return min(n, max(SHORTLIST_FACTOR * top, SHORTLIST_MIN))


def similar(catalog, query, *, top=10, metric=None, shortlist=None, columns=None):
    """The ``top`` tiles of ``catalog`` nearest to ``query`` (a tile's name or path, a cloud or
    an archive file, a PointCloud or a Signature; ``columns`` of a text cloud), best first,
    ranked by ``metric`` (default "distance", the combined distance; or one metric's key).
    ``shortlist`` sets how many tiles get the full metrics (default :func:`shortlist_size`;
    ``len(catalog)`` for all). A query that is a tile of the catalogue is left out of the
    answer (it would come first, at distance 0): the answer is the other tiles."""
    keys = catalog.keys
    metric = metric or "distance"
    if metric not in ("distance",) + keys:
        raise LidarSigError(f"unknown metric {metric!r}; use distance or one of {', '.join(keys)}")
    top = whole_number(top, "top (how many tiles to list)", low=1)
    if shortlist is not None:
        shortlist = whole_number(shortlist, f"{arg('shortlist')} (the tiles given every metric, at least the {top} "
                                            f"listed, {arg('top')})", low=top)
    q = catalog.query(query, columns=columns)
    others = np.flatnonzero(np.arange(len(catalog)) != (-1 if q.index is None else q.index))
    n = len(others)
    if n == 0:
        raise LidarSigError(f"the catalogue holds no tile but the query {q.name}: nothing to compare it with",
                            path=catalog.path)
    top = min(top, n)
    size = shortlist_size(top, n) if shortlist is None else min(n, shortlist)
    spread = catalog.spread
    screen = {k: v[0] for k, v in screening(q.features, catalog.features, catalog.labelled).items()}
    screen_keys = tuple(screen)
    if metric in SCREENING:
        rough = as_distance(metric, screen[metric])
    else:
        rough = combine(screen, spread, screen_keys)
    order = others[np.argsort(rough[others], kind="stable")]
    chosen = order[:size]
    totals = catalog.total_rasters(chosen.tolist())
    mask = catalog.frame.mask()

    def full(i):  # Sg made from the counts, then every metric: image work that frees the GIL
        sg = sg_image(totals[i], catalog.features.n_points[i], catalog.frame)
        values = pair_metrics(q.features, catalog.features.row(i), q.sg, sg, mask, keys)
        distance = float(combine(values, spread, keys))
        rank_by = distance if metric == "distance" else float(as_distance(metric, values[metric]))
        return rank_by, int(i), distance, values

    with ThreadPoolExecutor(max_workers=os.cpu_count() or 1) as pool:
        rows = list(pool.map(full, chosen))
    rows.sort(key=lambda r: (r[0], r[1]))
    results = []
    for rank, (_, i, distance, values) in enumerate(rows[:top], 1):
        results.append({"rank": rank, "name": catalog.columns["name"][i], "path": catalog.columns["path"][i],
                        "distance": distance, **{k: float(values[k]) for k in keys}})
    certain = size >= n or metric in SCREENING
    if not certain and metric == "distance":
        bound = combine(screen, spread, screen_keys)[order[size]] * len(screen_keys) / len(keys)
        certain = bool(bound >= rows[top - 1][0])
    every = "every other tile" if q.index is not None else "every tile"
    how = (every if size >= n else
           f"the {size} tiles nearest by {metric if metric in SCREENING else 'the screening distance'} "
           f"({', '.join(screen_keys)})")
    info = {"size": size, "tiles": n, "query_left_out": q.index is not None, "rule": f"max({SHORTLIST_FACTOR} x top, {SHORTLIST_MIN})"
            if shortlist is None else "given", "screened_by": how, "certain": certain,
            "image_metrics": list(IMAGE)}
    return Similar({"name": q.name, "kind": q.kind, "tile": q.index is not None}, metric,
                   SimilarTiles(results, metric=metric, keys=keys), info, {k: spread[k] for k in keys},
                   catalog, [i for _, i, _, _ in rows[:top]])
