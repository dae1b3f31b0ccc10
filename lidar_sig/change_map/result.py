"""The change map as a result: the per-cell table and the grid, the cells ranked by their score,
rasters of any field, plain values for JSON, and the files it is saved as (GeoTIFF, PNG, HTML)."""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..crs import crs_name
from ..errors import LidarSigError, whole_number
from ..metrics import METRIC_KEYS, METRICS
from ..progress import step
from ..signature import Frame
from .cells import CELL_FRAME, cell_signature
from .epochs import Epoch
from .grid import Grid

#: Metric that ranks the cells by default (docs/changes.md): delta_KL of the class distributions
#: where both epochs are labelled, else d_EMD-Info (GEOMETRIC_SCORE).
SCORE = "kl"
#: Thresholds of the default score at which docs/changes.md gives precision and recall.
THRESHOLDS = (0.05, 0.1, 0.25, 0.5)
GEOMETRIC_SCORE = "emd_info"


def score_values(table, score):
    """The ranking values of the per-cell ``table`` by metric ``score``: the metric itself, or
    1 - s_SSIM for ``"ssim"``, so that a larger score always means more change."""
    return 1.0 - table["ssim"] if score == "ssim" else table[score]


@dataclass
class ChangeMap:
    """The result of :func:`lidar_sig.change_map.changes`.

    Attributes
    ----------
    table : numpy structured array
        One record per cell of the grid, row-major (row 0 north): ``row``, ``col``, cell bounds
        ``x_min, y_min, x_max, y_max`` (CRS coordinates), ``points_a``, ``points_b``,
        ``defined_a``, ``defined_b`` (those with defined saliency), ``undefined_a``,
        ``undefined_b`` (share of the cell's points with undefined saliency), ``valid`` (both
        epochs hold ``min_points`` points with defined saliency or more), the metrics of
        :data:`lidar_sig.metrics.METRIC_KEYS` and ``score``; metrics are NaN where ``valid`` is
        False.
    classes_a, classes_b : (cells, C) int64
        Points of each class of ``class_table`` per cell, in each epoch.
    grid : Grid
    score : str
        The metric that ranks the cells (a key of METRIC_KEYS); the table's ``score`` holds its
        values, 1 - s_SSIM for ``"ssim"``, so that a larger score always means more change.
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

    @property
    def transform(self):
        """The grid's affine transform: an ``affine.Affine`` when affine (installed with
        rasterio) is present, else the 6-tuple (a, b, c, d, e, f) in rasterio's order (see
        :attr:`Grid.transform`)."""
        try:
            from affine import Affine
        except ImportError:
            return self.grid.transform
        return Affine(*self.grid.transform)

    def raster(self, name):
        """(rows, cols) float64 raster of the table's field ``name``, row 0 north; NaN where
        the cell has no data (for metrics and the score)."""
        return np.asarray(self.table[name], dtype=np.float64).reshape(self.grid.rows, self.grid.cols)

    def ranked(self, n=None):
        """Flat indices of the valid cells, most changed (largest score) first; the first ``n``."""
        if n is not None:
            n = whole_number(n, "the number of cells")
        valid = np.flatnonzero(self.table["valid"])
        order = valid[np.argsort(-self.table["score"][valid], kind="stable")]
        return order if n is None else order[:n]

    def signatures(self, flat):
        """(Signature of A, Signature of B) of cell ``flat``, as the metrics saw them."""
        labelled = bool(self.class_table.names)
        return tuple(cell_signature(e, np.flatnonzero(e.cells == flat), self.class_table, labelled, self.frame)
                     for e in (self.a, self.b))

    def to_pandas(self):
        """The table as a pandas DataFrame (needs pandas)."""
        try:
            import pandas as pd
        except ImportError:
            raise LidarSigError("to_pandas needs pandas: pip install pandas") from None
        return pd.DataFrame(self.table)

    def composition(self, flat):
        """{class name: [points in A, points in B]} of cell ``flat``, classes present in either."""
        names = self.class_table.class_names
        a, b = self.classes_a[flat], self.classes_b[flat]
        return {names[k]: [int(a[k]), int(b[k])] for k in np.flatnonzero((a > 0) | (b > 0))}

    def top(self, n=10):
        """The ``n`` most changed cells as plain dicts (rank, bounds, counts, metrics, classes)."""
        out = []
        for rank, flat in enumerate(self.ranked(n), 1):
            rec = self.table[flat]
            item = {"rank": rank, "row": int(rec["row"]), "col": int(rec["col"]),
                    "bounds": [float(rec[k]) for k in ("x_min", "y_min", "x_max", "y_max")],
                    "points_a": int(rec["points_a"]), "points_b": int(rec["points_b"]),
                    "undefined_a": float(rec["undefined_a"]), "undefined_b": float(rec["undefined_b"]),
                    "score": float(rec["score"])}
            item.update({k: _plain(rec[k]) for k in METRIC_KEYS})
            item["classes"] = self.composition(flat)
            out.append(item)
        return out

    def to_dict(self, n=10):
        """Everything a ``--json`` user needs: the grid, the settings and the ``n`` top cells."""
        a, b, c, d, e, f = self.grid.transform
        return {"a": self.a.name, "b": self.b.name, "cell_m": self.cell, "cell_crs_units": self.grid.size,
                "units": self.units.describe(), "crs": crs_name(self.crs), "min_points": self.min_points,
                "score": self.score, "render": self.render, "frame_px": self.frame.size,
                "grid": {"rows": self.grid.rows, "cols": self.grid.cols, "transform": [a, b, c, d, e, f],
                         "cells": self.grid.n_cells, "valid": int(self.table["valid"].sum())},
                "method": self.method, "top": self.top(n)}

    def save(self, path, *, overwrite=False):
        """Write by extension: ``.tif``/``.tiff`` a GeoTIFF of every metric (needs rasterio:
        ``pip install lidar-sig[geo]``), ``.png`` the map, ``.html`` the report."""
        ext = Path(path).suffix.lower()
        if ext in (".tif", ".tiff"):
            from ..io.geotiff import write_geotiff

            names = ("score",) + METRIC_KEYS + ("points_a", "points_b", "undefined_a", "undefined_b")
            bands = [self.raster(n) for n in names]
            for k, n in enumerate(names):  # counts and shares say nothing where a cell is empty
                if n.startswith("undefined"):
                    bands[k] = np.where(self.raster(n.replace("undefined", "points")) > 0, bands[k], np.nan)
            descriptions = [_band_description(n, self.score) for n in names]
            with step(f"writing {Path(path).name}", bands=len(names)):
                write_geotiff(path, bands, descriptions, self.grid.transform, self.crs, overwrite=overwrite)
        elif ext == ".png":
            from ..io.png import write_png
            from ..reporting import change_map_image

            with step(f"writing {Path(path).name}"):
                write_png(path, change_map_image(self), overwrite=overwrite)
        elif ext in (".html", ".htm"):
            self.report().save(path, overwrite=overwrite)
        else:
            raise LidarSigError(f"cannot write a change map as {ext or '(no extension)'!r}; use .tif, .png "
                                "or .html", path=path)

    def report(self):
        """The HTML report: the map over a top view of both epochs and the signatures of the top
        cells side by side (:class:`lidar_sig.reporting.Report`)."""
        from ..reporting import changes_report

        return changes_report(self)


def _plain(value):
    value = float(value)
    return None if math.isnan(value) else value


def _band_description(name, score):
    names = {m.key: f"{m.name}: {m.short}" for m in METRICS}
    ranking = names[score].split(":")[0]
    text = {"score": f"score: {'1 - ' if score == 'ssim' else ''}{ranking}, the ranking metric",
            "points_a": "points of epoch A", "points_b": "points of epoch B",
            "undefined_a": "share of A's points with undefined saliency",
            "undefined_b": "share of B's points with undefined saliency"}
    return text.get(name) or names[name]
