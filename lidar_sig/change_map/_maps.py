"""The change map as a result: the per-cell table and the grid, each metric's level of
detection, the cells ranked (significant ones first), rasters of any field, plain values for
JSON, and the files it is saved as (GeoTIFF with its QGIS style, GeoPackage of the cells, the
later epoch's points with their cell's change, PNG, HTML)."""
from __future__ import annotations

import math
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ..method.class_maps import class_scheme_warnings
from ..method.crs import crs_name
from ..base.errors import LidarSigError, as_path, whole_number
from ..metrics import METRIC, METRIC_NAMES, METRICS
from ..base.progress import step
from ..method.signature_raster import Frame
from ..base.views import Records
from ._cells import CELL_FRAME, CHANGE_KEYS, COVERAGE, COVERAGE_CHANGES
from ._density import LEAST_DENSITY
from ._epochs import Epoch
from ._grid import Grid
from ._heights import HEIGHT, HEIGHT_NAME
from ._lod import CONFIDENCE, Levels, level_from_sampling, p_values, pooled_confidence, q_values, sampling_part

if TYPE_CHECKING:
    from ..reporting import Report
    from ..method.signature_raster import Signature

#: Metric that ranks the cells by default (docs/changes.md): delta_KL of the class distributions
#: where both epochs are labelled in overlapping class schemes, else LABEL_FREE_SCORE.
SCORE = "kl"
#: Metric that ranks the cells where the labels cannot (unlabelled epochs, or class schemes that
#: barely overlap): delta_FV, which separated the edited cells best among the metrics that do not
#: depend on the labels (docs/changes.md).
LABEL_FREE_SCORE = "fv"
#: Bands of the change map's GeoTIFF before the metrics and after them.
BANDS = ("score", "lod", "significant")
COUNT_BANDS = ("height_lod", "points_a", "points_b", "undefined_a", "undefined_b", "coverage")
#: Bands after those, so that the first seventeen keep their numbers: how far each cell lies from
#: its level of detection (the band the map's style draws), its q-value, and whether it changed
#: (significant, or appeared or vanished inside the other epoch's footprint).
LEVEL_BANDS = ("lod_ratio", "q", "changed")
#: The smallest float32 above 1: the lod_ratio of a significant cell whose quotient rounds to 1,
#: so that "above 1" is "significant" in the table and in the GeoTIFF's float32 band alike.
ABOVE_ONE = float(np.nextafter(np.float32(1.0), np.float32(2.0)))
#: Below this density (points per m²) the change map finds fewer of the known changes
#: (docs/changes.md, power table): a map without a significant cell says so.
SPARSE = LEAST_DENSITY
#: Above this survey spread (tau, log scale: a factor of 2 from cell to cell) the level of
#: detection is called wide when no cell is significant.
WIDE_TAU = float(np.log(2.0))
#: Names of what the change map compares: the metrics' and delta_H's.
NAMES = {**METRIC_NAMES, HEIGHT: HEIGHT_NAME}


def oriented(values, metric):
    """A metric's values oriented so that larger means more different: its distance form
    (:meth:`lidar_sig.metrics.Metric.distance`: 1 - s_SSIM for s_SSIM), delta_H as it is."""
    return METRIC[metric].distance(values) if metric in METRIC else values


def score_name(key):
    """The name of the ranking values of ``key``: its distance form's (1 - s_SSIM), delta_H's."""
    return METRIC[key].distance_name if key in METRIC else NAMES[key]


def score_values(table, score):
    """The ranking values of the per-cell ``table`` by metric ``score``: the metric itself, or
    1 - s_SSIM for ``"ssim"``, so that a larger score always means more change."""
    return oriented(table[score], score)


def sampling_parts(null):
    """{metric key: (mu0, sigma, defined)} the sampling part of every metric's level of detection
    (:func:`~lidar_sig.change_map._lod.sampling_part`) from the replicates ``null`` (cells,
    replicates, metrics) of :func:`~lidar_sig.change_map._cells.null_metrics`, oriented as the
    scores are."""
    return {k: sampling_part(oriented(null[:, :, m], k)) for m, k in enumerate(CHANGE_KEYS)}


def metric_levels(table, null=None, *, confidence=CONFIDENCE, sampled=None):
    """The :class:`~lidar_sig.change_map._lod.Levels` (metric key -> Level) of every metric, from
    the table's observed values and the replicates ``null`` (cells, replicates, metrics) of
    :func:`~lidar_sig.change_map._cells.null_metrics`, or their sampling parts ``sampled``
    (:func:`sampling_parts`, as a survey-scale map gathers them from its work units)."""
    sampled = sampling_parts(null) if sampled is None else sampled
    return Levels({k: level_from_sampling(oriented(table[k], k), *sampled[k], table["valid"], confidence=confidence,
                                          key=k)
                   for k in CHANGE_KEYS})


def geometry_only_note(bare, score=None):
    """The note that the epochs ``bare`` (their names) have no class labels, so that the cells
    are compared by geometry only, ranked by ``score`` (default :data:`LABEL_FREE_SCORE`)."""
    return (f"{bare} has no class labels: the cells are compared by geometry only (ranked by "
            f"{METRIC_NAMES[score or LABEL_FREE_SCORE]}) and every epoch's points are shown as one class")


def scheme_warnings(binned, classes, names, *, ranked_by=None):
    """Per interval, the warnings that its two epochs' class codes barely overlap
    (:func:`lidar_sig.method.class_maps.class_scheme_warnings`), saying what the ranking then is."""
    consequence = "delta_KL and L1 measure the classification schemes as much as the land"
    if ranked_by is None:
        consequence += (f"; the cells are ranked by {METRIC_NAMES[LABEL_FREE_SCORE]}, which does not depend on the "
                        "labels (--class-map merges codes to compare the classes)")
    return [class_scheme_warnings(binned[k].classes.sum(axis=0), binned[k + 1].classes.sum(axis=0),
                                  classes.class_names, names[k:k + 2], consequence=consequence)
            for k in range(len(binned) - 1)]


def _where(cell):
    return f"{cell['bounds'][0]:.1f}, {cell['bounds'][1]:.1f}"


def _value(value, digits=4):
    return "-" if value is None else f"{value:.{digits}f}"


class TopCells(Records):
    """What :meth:`ChangeMap.top` returns: the most changed cells, most first, a dict each; a
    list that prints in one line (each cell's rank, row and column, score and level) and shows a
    card (a row per cell)."""

    title = "cells"
    columns = (("rank", lambda c: c["rank"], True), ("row, col", lambda c: f"{c['row']}, {c['col']}", False),
               ("x, y min", _where, True), ("points A", lambda c: f"{c['points_a']:,}", True),
               ("points B", lambda c: f"{c['points_b']:,}", True), ("score", lambda c: _value(c["score"]), True),
               ("level", lambda c: _value(c["lod"]), True), ("z", lambda c: _value(c["z"], 1), True),
               ("significant", lambda c: "yes" if c["significant"] else "no", False),
               ("points per class, A \u2192 B", lambda c: ", ".join(f"{k}\u00a0{a:,}\u00a0\u2192\u00a0{b:,}"
                                                                for k, (a, b) in c["classes"].items()), False))

    def summary(self):
        f = self.facts
        cells = "; ".join(f"{c['rank']} (row {c['row']}, col {c['col']}) {_value(c['score'], 3)} "
                          f"{'>' if c['lod'] is not None and c['score'] > c['lod'] else '<='} {_value(c['lod'], 3)}"
                          + (" *" if c["significant"] else "") for c in self[:4])
        more = "; ..." if len(self) > 4 else ""
        return (f"{len(self)} of {f.get('compared', '?')} compared cells, most changed first (score vs its level, "
                f"{f.get('score', '?')}; * significant): {cells}{more}")


@dataclass(repr=False)
class ChangeMap:
    """The result of :func:`lidar_sig.change_map.changes` for two epochs.

    Attributes
    ----------
    table : numpy structured array
        One record per cell of the grid, row-major (row 0 north): ``row``, ``col``, cell bounds
        ``x_min, y_min, x_max, y_max`` (CRS coordinates), ``points_a``, ``points_b``,
        ``defined_a``, ``defined_b`` (those with defined saliency), ``undefined_a``,
        ``undefined_b`` (share of the cell's points with undefined saliency), ``valid`` (both
        epochs hold ``min_points`` points with defined saliency or more), ``coverage`` (the
        code of :data:`~lidar_sig.change_map._cells.COVERAGE`), the metrics of
        :data:`lidar_sig.metrics.METRIC_KEYS` and ``height`` (delta_H, m), and the ranking's
        ``score``, ``lod`` (its level of detection), ``height_lod`` (delta_H's), ``z``,
        ``lod_ratio`` (the larger of score / lod and delta_H / height_lod: above 1 exactly where
        significant) and ``significant`` (:meth:`rank_by`); NaN (False) where ``valid`` is False.
    classes_a, classes_b : (cells, C) int64
        Points of each class of ``class_table`` per cell, in each epoch.
    grid : Grid
    score : str
        The metric that ranks the cells (a key of METRIC_KEYS); the table's ``score`` holds its
        values, 1 - s_SSIM for ``"ssim"``, so that a larger score always means more change.
    levels : Levels
        {metric key or "height": :class:`~lidar_sig.change_map._lod.Level`}: every metric's level of
        detection and significance per cell (a dict that prints in one line).
    cell_rule, min_points_rule : str
        ``"auto"`` (chosen from the epochs' densities) or ``"given"``.
    density : tuple
        Points per m² of each epoch (:func:`~lidar_sig.change_map._density.density`).
    sampled : tuple
        Points per m² of each epoch's sample, the points its cells take (at most
        :data:`~lidar_sig.change_map._density.SAMPLE_DENSITY`; docs/changes.md, "The points a
        cell's signature takes"); empty when not known.
    warnings : list
        What may make the map mislead (class schemes, too few cells for the survey part).
    """

    table: np.ndarray
    classes_a: np.ndarray
    classes_b: np.ndarray
    grid: Grid
    crs: object
    units: object
    cell: float
    min_points: int
    score: str
    render: str
    class_table: object
    a: Epoch
    b: Epoch
    frame: Frame = CELL_FRAME
    method: dict = field(default_factory=dict)
    levels: Levels = field(default_factory=Levels)
    confidence: float = CONFIDENCE
    cell_rule: str = "given"
    min_points_rule: str = "given"
    density: tuple = ()
    sampled: tuple = ()
    warnings: list = field(default_factory=list)
    timings: dict = field(default_factory=dict)
    #: What was read when the epochs were clipped to an area of interest (lidar_sig.io.clip.Reading), or None.
    reading: Any = None

    def __repr__(self):
        from ..base.views import one_line, short_name

        return one_line(f"<ChangeMap {self.grid.rows} x {self.grid.cols} cells of {self.cell:g} m, "
                        f"{int(self.table['valid'].sum())} compared, {self.n_significant} significant by {self.score} "
                        f"({self.confidence:.0%}); {short_name(self.a.name)} -> {short_name(self.b.name)}>")

    def thumbnail(self, size: int = 240) -> np.ndarray:
        """(H, W, 3) uint8 picture of the map's cells, about ``size`` pixels on its longer side
        (row 0 north): the report's and the PNG's map without its frame
        (:func:`lidar_sig.reporting.map_image.cells_picture`): each cell in its colour on the
        one colour scale of change, significant cells outlined, the five most changed numbered."""
        from ..reporting.map_image import cells_picture

        return cells_picture(self, display=size)[0]

    def _repr_html_(self):
        """A notebook's view: the map's thumbnail, its counts and the most changed cells."""
        return self._card("ChangeMap")

    def _card(self, title):
        from ..base.views import card
        from ..reporting.change_scale import legend_text

        rows = [(item["rank"], f"{item['bounds'][0]:.1f}, {item['bounds'][1]:.1f}", item["points_a"], item["points_b"],
                 f"{item['score']:.4f}", "yes" if item["significant"] else "no") for item in self.top(5)]
        facts = [f"{self.a.name} -> {self.b.name}", f"{self.grid.rows} x {self.grid.cols} cells of {self.cell:g} m, "
                 f"{int(self.table['valid'].sum()):,} compared, {self.n_significant:,} significant "
                 f"({self.confidence:.0%} level of detection of {self.score}); {self.n_changed:,} changed with the "
                 "appeared and vanished land inside the other epoch's footprint"]
        return card(title, facts + [f"warning: {w}" for w in self.warnings],
                    header=("rank", "x, y min", "points A", "points B", "score", "significant"), rows=rows,
                    numeric=(0, 2, 3, 4), image=self.thumbnail(), width=240,
                    note=legend_text())

    def rank_by(self, score: str) -> None:
        """Fill the table's ranking fields from metric ``score`` and delta_H, the two tests of
        a cell (:meth:`tests`): ``score``, its level ``lod`` and delta_H's ``height_lod`` at the
        confidence of each of the two tests (:func:`~lidar_sig.change_map._lod.pooled_confidence`),
        ``z`` the larger of their z, ``significant`` where either exceeds its level, and
        ``lod_ratio`` the larger of score / lod and delta_H / height_lod: how far the cell lies
        from its levels (1 at the level), above 1 exactly where significant; ``p`` and ``q``
        each compared cell's p-value over the two tests and its q-value over the map
        (:func:`~lidar_sig.change_map._lod.p_values`, :func:`~lidar_sig.change_map._lod.q_values`);
        ``changed`` the significant cells and the appeared or vanished ones inside the other
        epoch's footprint (``in_footprint``): the map's one answer to "what changed?"."""
        if score not in self.levels or score == HEIGHT:
            raise LidarSigError(f"unknown score {score!r}; rank by one of {', '.join(k for k in self.levels if k != HEIGHT)}")
        self.score = score
        each = pooled_confidence(self.confidence, len(self.tests))
        t = self.table
        t["score"] = score_values(t, score)
        t["lod"] = self.levels[score].lod_at(each)
        t["height_lod"] = self.levels[HEIGHT].lod_at(each)
        with np.errstate(invalid="ignore", divide="ignore"):
            t["z"] = np.fmax(self.levels[score].z, self.levels[HEIGHT].z)
            t["significant"] = t["valid"] & ((t["score"] > t["lod"]) | (t[HEIGHT] > t["height_lod"]))
            ratio = np.fmax(t["score"] / t["lod"], t[HEIGHT] / t["height_lod"])
        t["lod_ratio"] = np.where(t["valid"], np.where(t["significant"], np.fmax(ratio, ABOVE_ONE), ratio), np.nan)
        t["p"] = np.nan
        t["p"][t["valid"]] = p_values(t["z"][t["valid"]], len(self.tests))  # one call per compared cell
        t["q"] = q_values(t["p"])
        t["changed"] = t["significant"] | (np.isin(t["coverage"], COVERAGE_CHANGES) & t["in_footprint"])

    @property
    def names(self) -> dict[str, str]:
        """{key: name} of everything the map compares: the metrics' names and delta_H."""
        return dict(NAMES)

    @property
    def score_name(self) -> str:
        """The name of the ranking values (the score's distance form: 1 - s_SSIM for s_SSIM)."""
        return score_name(self.score)

    @property
    def tests(self) -> tuple[str, ...]:
        """The metrics whose levels of detection decide a cell's significance: the score (what
        the cell is made of) and delta_H (how high it is), each at the confidence that keeps
        the map's (docs/changes.md, "Significance")."""
        return (self.score, HEIGHT)

    @property
    def n_significant(self) -> int:
        """Cells whose score exceeds its level of detection."""
        return int(self.table["significant"].sum())

    @property
    def n_changed(self) -> int:
        """Cells that changed: the significant ones and the appeared or vanished ones inside the
        other epoch's footprint (:meth:`coverage_changes`)."""
        return int(self.table["changed"].sum())

    def coverage_changes(self) -> dict[str, int]:
        """{"appeared": cells, "vanished": cells, "at the edges": cells}: the appeared and
        vanished cells inside the other epoch's footprint (change of coverage, counted as
        changed), and those at a survey's edge or in a gap of it larger than a hectare (not
        counted: the other survey did not reach there)."""
        t = self.table
        named = np.isin(t["coverage"], COVERAGE_CHANGES)
        return {"appeared": int(((t["coverage"] == 2) & t["in_footprint"]).sum()),
                "vanished": int(((t["coverage"] == 3) & t["in_footprint"]).sum()),
                "at the edges": int((named & ~t["in_footprint"]).sum())}

    @property
    def false_flags(self) -> float:
        """The number of significant cells expected to be unchanged land at most: each compared
        cell of unchanged land is flagged with chance 1 - confidence, so (1 - confidence) x the
        compared cells (docs/changes.md, "How many flags are false"); the table's ``q`` gives each
        flag's own false discovery rate."""
        return (1.0 - self.confidence) * int(self.table["valid"].sum())

    def answer(self) -> list[str]:
        """The map's answer to "what changed?" in lines: the changed cells (significant, and
        appeared or vanished inside the other epoch's footprint), how many flags may be false,
        and, on a map without a significant cell whose level is wide, why and where to look."""
        moved = self.coverage_changes()
        false = (f"; of the significant, expect up to {min(self.false_flags, self.n_significant):.1f} to be "
                 f"unchanged land ({1 - self.confidence:.0%} of the compared cells)" if self.n_significant else "")
        lines = [f"changed: {self.n_changed} cells ({self.n_significant} significant, {moved['appeared']} appeared "
                 f"and {moved['vanished']} vanished inside the other epoch's footprint; {moved['at the edges']} at a "
                 f"survey's edge or in a gap of it not counted){false}"]
        why = "" if self.n_significant else self.wide_because()
        if why:
            lines.append(f"no cell changed significantly and the level of detection is wide: {why}; the ranking "
                         "still says where to look first (the rows below)")
        return lines

    def wide_because(self) -> str:
        """Why this map's level of detection is wide, in words ("" where nothing says so): too
        few cells for the survey part, an epoch below 1 point/m², or scores of unchanged land
        that vary from cell to cell by more than a factor 2 (the survey part's spread tau)."""
        level = self.levels.get(self.score)
        if level is None or not level.n_compared:
            return ""
        if not level.survey:
            return f"{level.n_compared} compared cells are too few to learn what differs between the surveys"
        sparse = [f"{name} holds {d:.2g} points/m²" for name, d in zip("AB", self.density) if d < SPARSE]
        if sparse:
            return " and ".join(sparse) + f", below {SPARSE:g} point/m²"
        if level.tau > WIDE_TAU:
            return (f"the scores of unchanged land vary from cell to cell by a factor {np.exp(level.tau):.2g} "
                    f"(tau {level.tau:.2g}): the two surveys differ unevenly")
        return ""

    @property
    def transform(self) -> Any:
        """The grid's affine transform: an ``affine.Affine`` when affine (installed with
        rasterio) is present, else the 6-tuple (a, b, c, d, e, f) in rasterio's order (see
        :attr:`Grid.transform`)."""
        try:
            from affine import Affine
        except ImportError:
            return self.grid.transform
        return Affine(*self.grid.transform)

    def raster(self, name: str) -> np.ndarray:
        """(rows, cols) float64 raster of the table's field ``name``, row 0 north; NaN where
        the cell has no data (for metrics and the score)."""
        if not isinstance(name, str) or name not in self.table.dtype.names:
            raise LidarSigError(f"the change map has no field {name!r}; use one of {', '.join(self.table.dtype.names)}")
        return np.asarray(self.table[name], dtype=np.float64).reshape(self.grid.rows, self.grid.cols)

    def ranked(self, n: int | None = None) -> np.ndarray:
        """Flat indices of the valid cells, most changed first: the significant cells first,
        then by ``lod_ratio`` (how far the cell lies from its level of detection, the quantity
        every face colours it by: docs/changes.md, "Colours"), ties by z, then by score; the
        first ``n``."""
        if n is not None:
            n = whole_number(n, "the number of cells")
        valid = np.flatnonzero(self.table["valid"])
        t = self.table[valid]
        z = np.where(np.isnan(t["z"]), -np.inf, t["z"])
        ratio = np.where(np.isnan(t["lod_ratio"]), -np.inf, t["lod_ratio"])
        order = valid[np.lexsort((-t["score"], -z, -ratio, ~t["significant"]))]
        return order if n is None else order[:n]

    def signatures(self, flat: int) -> tuple[Signature, Signature]:
        """(Signature of A, Signature of B) of cell ``flat``, as the metrics saw them."""
        if isinstance(flat, bool) or not isinstance(flat, (int, np.integer)) or not 0 <= flat < self.grid.n_cells:
            raise LidarSigError(f"no cell {flat!r} in a grid of {self.grid.n_cells:,} cells; give a flat cell index "
                                "from the table (row x columns + col)")
        labelled = bool(self.class_table.names)
        return tuple(e.cell_signature(flat, self.grid, self.class_table, labelled, self.frame) for e in (self.a, self.b))

    def to_pandas(self) -> Any:
        """The table as a pandas DataFrame (needs pandas)."""
        try:
            import pandas as pd
        except ImportError:
            raise LidarSigError("to_pandas needs pandas: pip install pandas") from None
        return pd.DataFrame(self.table)

    def composition(self, flat: int) -> dict[str, tuple[int, int]]:
        """{class name: [points in A, points in B]} of cell ``flat``, classes present in either."""
        names = self.class_table.class_names
        a, b = self.classes_a[flat], self.classes_b[flat]
        return {names[k]: [int(a[k]), int(b[k])] for k in np.flatnonzero((a > 0) | (b > 0))}

    def top(self, n: int = 10) -> TopCells:
        """The ``n`` most changed cells as plain dicts (rank, bounds, counts, score, its level
        of detection, z, lod_ratio and significance, metrics, the metrics in which the cell changed
        significantly, classes), in a :class:`TopCells` list."""
        out = []
        for rank, flat in enumerate(self.ranked(n), 1):
            rec = self.table[flat]
            item = {"rank": rank, "row": int(rec["row"]), "col": int(rec["col"]),
                    "bounds": [float(rec[k]) for k in ("x_min", "y_min", "x_max", "y_max")],
                    "points_a": int(rec["points_a"]), "points_b": int(rec["points_b"]),
                    "undefined_a": float(rec["undefined_a"]), "undefined_b": float(rec["undefined_b"]),
                    "score": float(rec["score"]), "lod": _plain(rec["lod"]), "height_lod": _plain(rec["height_lod"]),
                    "z": _plain(rec["z"]), "lod_ratio": _plain(rec["lod_ratio"]), "p": _plain(rec["p"]),
                    "q": _plain(rec["q"]), "significant": bool(rec["significant"])}
            item.update({k: _plain(rec[k]) for k in CHANGE_KEYS})
            item["significant_metrics"] = [k for k in CHANGE_KEYS if k in self.levels
                                           and self.levels[k].significant[flat]]
            item["classes"] = self.composition(flat)
            out.append(item)
        return TopCells(out, compared=int(self.table["valid"].sum()), score=self.score)

    def drawn(self) -> Any:
        """(cells,) bool: the cells every face draws (:func:`~lidar_sig.change_map._layers.drawn_cells`):
        not the slivers of points a survey's edge leaves outside both footprints, which are
        drawn as not covered."""
        from ._layers import drawn_cells

        return drawn_cells(self)

    def coverage(self) -> dict[str, int]:
        """{state: cells} of every coverage state (:data:`~lidar_sig.change_map._cells.COVERAGE`):
        compared, appeared, vanished, too few points, not covered."""
        codes = np.bincount(self.table["coverage"].astype(np.int64), minlength=len(COVERAGE))
        return {name: int(codes[code]) for code, name in COVERAGE.items()}

    def uncompared(self, state: str) -> list[dict[str, Any]]:
        """The cells in coverage ``state`` ("appeared", "vanished", ...) as plain dicts: row,
        col, bounds, the points of each epoch, and whether it counts as changed (inside the
        other epoch's footprint)."""
        code = next((k for k, v in COVERAGE.items() if v == state), None)
        if code is None:
            raise LidarSigError(f"unknown coverage state {state!r}; use one of {', '.join(map(repr, COVERAGE.values()))}")
        t = self.table
        return [{"row": int(t["row"][c]), "col": int(t["col"][c]),
                 "bounds": [float(t[k][c]) for k in ("x_min", "y_min", "x_max", "y_max")],
                 "points_a": int(t["points_a"][c]), "points_b": int(t["points_b"][c]),
                 "changed": bool(t["changed"][c])}
                for c in np.flatnonzero(t["coverage"] == code)]

    def sample_text(self) -> str:
        """What the cells took of a denser epoch, "the cells take a sample of 5 points/m²", or ""
        when they took every point (docs/changes.md, "The points a cell's signature takes")."""
        thinned = sorted({round(float(s), 6) for s, d in zip(self.sampled, self.density) if s < d})
        return f"the cells take a sample of {thinned[0]:g} points/m²" if thinned else ""

    def settings(self) -> dict[str, Any]:
        """The grid and settings as plain values (``to_dict`` without the cells)."""
        a, b, c, d, e, f = self.grid.transform
        return {"a": self.a.name, "b": self.b.name, "cell_m": self.cell, "cell_rule": self.cell_rule,
                "cell_crs_units": self.grid.size, "units": self.units.describe(), "crs": crs_name(self.crs),
                "min_points": self.min_points, "min_points_rule": self.min_points_rule,
                "density": [round(float(v), 4) for v in self.density],
                "sampled_density": [round(float(v), 4) for v in self.sampled], "score": self.score,
                "confidence": self.confidence, "render": self.render, "frame_px": self.frame.size,
                "grid": {"rows": self.grid.rows, "cols": self.grid.cols, "transform": [a, b, c, d, e, f],
                         "cells": self.grid.n_cells, "valid": int(self.table["valid"].sum()),
                         "significant": self.n_significant, "changed": self.n_changed,
                         "false_flags": round(self.false_flags, 2)},
                "wide_because": self.wide_because() if not self.n_significant else "", "answer": self.answer(),
                "coverage": {"cells": self.coverage(), "codes": {str(k): v for k, v in COVERAGE.items()},
                             "changed": self.coverage_changes(),
                             "appeared": self.uncompared("appeared"), "vanished": self.uncompared("vanished")},
                "levels": {k: {"beta": v.beta, "tau": v.tau, "survey": v.survey,
                               "significant": int(v.significant.sum())} for k, v in self.levels.items()
                           if np.isfinite(v.mu0).any()},
                "warnings": list(self.warnings), "method": self.method,
                "work_units": self.timings.get("units")}

    def to_dict(self, n: int = 10) -> dict[str, Any]:
        """Everything a ``--json`` user needs: the grid, the settings, each metric's survey part
        and significant cells, and the ``n`` top cells (all compared cells when ``n`` is at
        least their number)."""
        return {**self.settings(), "top": list(self.top(n))}

    def metadata_tags(self):
        """Text tags of the GeoTIFF: the settings a reader needs to interpret the bands."""
        return {"cell_m": f"{self.cell:g}", "cell_rule": self.cell_rule, "min_points": str(self.min_points),
                "min_points_rule": self.min_points_rule, "density_points_per_m2": ", ".join(
                    f"{v:.4g}" for v in self.density), "sampled_points_per_m2": ", ".join(
                    f"{v:.4g}" for v in self.sampled), "score": self.score, "confidence": f"{self.confidence:g}",
                "compared": str(int(self.table["valid"].sum())), "significant": str(self.n_significant),
                "changed": str(self.n_changed),
                "epoch_a": self.a.name, "epoch_b": self.b.name}

    def bands(self, prefix="", meaning_prefix=None):
        """(rasters, descriptions, meanings) of the GeoTIFF's bands: the score, its level of
        detection, significant (0/1), every metric and delta_H, delta_H's level, the points of
        each epoch, their undefined shares, the coverage state and lod_ratio; NaN where there is
        no data. A description is short (QGIS shows it as the band's name and its legend's
        title); its meaning, in full, is the band's metadata. ``prefix`` starts each description
        and ``meaning_prefix`` (default ``prefix``) each meaning (a series' interval)."""
        names = self.band_names
        rasters = []
        for n in names:
            r = self.raster(n)
            if n == "significant":
                r = np.where(self.raster("valid") > 0, r, np.nan)
            elif n.startswith("undefined"):  # shares say nothing where a cell is empty
                r = np.where(self.raster(n.replace("undefined", "points")) > 0, r, np.nan)
            elif n == "changed":  # an answer where a cell is compared, appeared or vanished
                r = np.where(np.isin(self.raster("coverage"), (1, *COVERAGE_CHANGES)), r, np.nan)
            rasters.append(r)
        meaning_prefix = prefix if meaning_prefix is None else meaning_prefix
        return (rasters, [prefix + _band_title(n, self.score) for n in names],
                [meaning_prefix + _band_description(n, self.score, self.confidence) for n in names])

    @property
    def band_names(self) -> tuple[str, ...]:
        """The names of the GeoTIFF's bands, in order (:meth:`bands`)."""
        return BANDS + CHANGE_KEYS + COUNT_BANDS + LEVEL_BANDS

    def save(self, path: str | os.PathLike[str], *, overwrite: bool = False) -> None:
        """Write by extension: ``.tif``/``.tiff`` a Cloud-Optimized GeoTIFF of the score, its
        level of detection, significance and every metric (needs rasterio: ``pip install
        lidar-sig[geo]``) with its QGIS style beside it (``.qml``: lod_ratio in fixed colours),
        ``.gpkg`` the cells as a GeoPackage layer (:func:`~lidar_sig.change_map._layers.cell_features`),
        a point-cloud extension (``.laz``, ``.las``, ``.ply``, ``.csv``, ...) the later epoch's
        points with their saliency and their cell's change (ChangeScore, ChangeLoD,
        ChangeSignificant), ``.png`` the map, ``.html`` the report."""
        from ..io import output_group
        from ..io.formats import IMAGE, POINTS, RASTER, REPORT, VECTOR, format_of

        fmt = format_of(as_path(path, "saving a change map"))
        holds = set(fmt.holds) if fmt is not None else set()
        if RASTER in holds:
            from ..io.geotiff import write_geotiff
            from ..io.styles import style_path, write_style
            from ._layers import level_style

            rasters, descriptions, meanings = self.bands()
            with step(f"writing {Path(path).name}", bands=len(rasters)), output_group():
                write_geotiff(path, rasters, descriptions, self.grid.transform, self.crs, overwrite=overwrite,
                              tags=self.metadata_tags(), meanings=meanings)
                write_style(style_path(path), level_style(self.band_names.index("lod_ratio") + 1,
                                                          self.table["lod_ratio"]), overwrite=overwrite)
        elif VECTOR in holds:
            from ..io.geopackage import write_geopackage
            from ._layers import cells_layer

            with step(f"writing {Path(path).name}", cells=int(self.table["valid"].sum())):
                write_geopackage(path, [cells_layer(self)], overwrite=overwrite)
        elif POINTS in holds:
            from ._layers import point_change

            with step(f"writing {Path(path).name}", points=self.b.n_points):
                self.b.write_points(path, lambda xy: point_change(self, xy), overwrite=overwrite)
        elif IMAGE in holds:
            from ..io.png import write_png
            from ..reporting import change_map_image

            with step(f"writing {Path(path).name}"):
                write_png(path, change_map_image(self), overwrite=overwrite)
        elif REPORT in holds:
            self.report().save(path, overwrite=overwrite)
        else:
            ext = Path(path).suffix.lower()
            raise LidarSigError(f"cannot write a change map as {ext or '(no extension)'!r}; use .tif, .gpkg, "
                                ".png, .html or a point-cloud format (.laz, .las, .ply, .csv, ...)", path=path)

    def close(self) -> None:
        """Remove the work folder of a map made in work units (docs/changes.md, "At survey
        scale"): its per-cell values remain, its points go. Nothing for a map of one block."""
        for e in (self.a, self.b):
            if hasattr(e, "close"):
                e.close()

    def report(self) -> Report:
        """The HTML report: the map over a top view of both epochs and the signatures of the top
        cells side by side (:class:`lidar_sig.reporting.Report`)."""
        from ..reporting import changes_report

        return changes_report(self)


def _plain(value):
    value = float(value)
    return None if math.isnan(value) else value


#: The most characters of a band's short description: QGIS titles the band's legend "Band 18: "
#: and the description, within 60 characters (a Layers panel's width, a print layout's legend),
#: a series' interval "[2] " before it.
BAND_TITLE_MAX = 47


def _band_title(name, score):
    """The short description of a band: its name and, where short, what it holds (at most
    :data:`BAND_TITLE_MAX` characters; the full text is :func:`_band_description`)."""
    titles = {"score": f"score: {score_name(score)}, the ranking metric",
              "lod": "lod: level of detection of the score",
              "height_lod": f"height_lod: level of detection of {HEIGHT_NAME} (m)",
              "significant": "significant: 1 above its level of detection",
              "points_a": "points of epoch A", "points_b": "points of epoch B",
              "undefined_a": "share of A's points undefined", "undefined_b": "share of B's points undefined",
              "coverage": "coverage: " + ", ".join(f"{k} {v}" for k, v in sorted(COVERAGE.items()) if 0 < k < 4),
              "q": "q: the cell's q-value", "changed": "changed: 1 significant, appeared or vanished",
              "lod_ratio": "lod_ratio: x its level of detection", HEIGHT: f"{HEIGHT_NAME}: EMD of heights (m)"}
    names = {m.key: m.name for m in METRICS}
    return (titles.get(name) or names[name])[:BAND_TITLE_MAX]


def _band_description(name, score, confidence=CONFIDENCE):
    names = {m.key: f"{m.name}: {m.short}" for m in METRICS}
    names[HEIGHT] = f"{HEIGHT_NAME}: EMD of heights above the cell's lowest points (m)"
    ranking = score_name(score)
    each = f"{pooled_confidence(confidence, 2):.1%}"
    text = {"score": f"score: {ranking}, the ranking metric",
            "lod": f"lod: level of detection of the score ({ranking} of unchanged land at {each})",
            "height_lod": f"height_lod: level of detection of {HEIGHT_NAME} (m, unchanged land at {each})",
            "significant": f"significant: 1 where the score or {HEIGHT_NAME} exceeds its level of detection (the "
                           f"two at {confidence:.0%} together), 0 where not",
            "points_a": "points of epoch A", "points_b": "points of epoch B",
            "undefined_a": "share of A's points with undefined saliency",
            "undefined_b": "share of B's points with undefined saliency",
            "coverage": "coverage: " + ", ".join(f"{k} {v}" for k, v in COVERAGE.items())
                        + " (only B covers the cell: appeared; only A: vanished)",
            "q": "q: the cell's q-value, the false discovery rate at which it would be flagged (Benjamini-Hochberg "
                 "over the compared cells)",
            "changed": "changed: 1 where the cell changed significantly, or appeared or vanished inside the other "
                       "epoch's footprint; 0 where not; no data with too few points or none",
            "lod_ratio": f"lod_ratio: how far the cell lies from its level of detection; the larger of score / lod "
                         f"and {HEIGHT_NAME} / height_lod; 1 at the level, above 1 exactly where significant"}
    return text.get(name) or names[name]
