"""Where did it change? A registration-free change map: per-cell signature distances.

The paper compares two clouds as wholes and names the price: the signature "does not preserve
the spatial contextual information" (Sreevalsan-Nair & Mohapatra, Sec. 6). Signatures are
additive count rasters (SPEC 5), so a regular grid of cells in the survey's CRS gives one
signature per cell per epoch from the per-point saliency, with no point-to-point matching: a
shift of a few decimetres between the epochs moves a few points across a cell edge, nothing more.

- Saliency is computed on each WHOLE epoch (so that cell edges do not cut neighbourhoods), then
  the points are binned into cells.
- Cells are squares of ``cell`` metres, aligned to multiples of the cell size in the CRS's
  coordinates (converted to the CRS unit), so that grids of different runs agree. A cell is
  half-open: [x0 + i s, x0 + (i + 1) s) x [y0 + j s, y0 + (j + 1) s).
- A cell where either epoch holds fewer than ``min_points`` points gets no data
  (:data:`MIN_POINTS`, docs/changes.md says why).
- Per-cell signatures use a :data:`CELL_FRAME` of 64 px instead of 512 (docs/changes.md).
- Cells are ranked by :data:`SCORE` (chosen by measurement on the edited IGN epoch).
"""
from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .crs import same_crs
from .errors import LidarSigError, LidarSigWarning, whole_number
from .progress import step
from .signature import Frame, Signature

#: Default cell side, in metres.
CELL = 25.0
#: Fewest points of a cell, in each epoch, for a signature worth comparing (docs/changes.md).
MIN_POINTS = 1000
#: Most cells a change map holds (its table takes about 200 bytes a cell).
MAX_CELLS = 4_000_000
#: Frame of the per-cell signatures: 64 px (2 px margin) instead of 512 (docs/changes.md).
CELL_FRAME = Frame(64, 2)
#: Metric that ranks the cells by default (docs/changes.md): delta_KL of the class distributions
#: where both epochs are labelled, else d_EMD-Info (GEOMETRIC_SCORE).
SCORE = "kl"
#: Thresholds of the default score at which docs/changes.md gives precision and recall.
THRESHOLDS = (0.05, 0.1, 0.25, 0.5)
GEOMETRIC_SCORE = "emd_info"
#: Metrics of a cell, in the order of the GeoTIFF's bands (keys of :func:`lidar_sig.metrics.compare`).
METRIC_KEYS = ("bhattacharyya", "ssim", "emd_info", "emd_img", "fv", "kl", "l1")
#: Fields of the per-cell table besides the metrics.
CELL_FIELDS = (("row", np.int32), ("col", np.int32), ("x_min", np.float64), ("y_min", np.float64),
               ("x_max", np.float64), ("y_max", np.float64), ("points_a", np.int64), ("points_b", np.int64),
               ("undefined_a", np.float64), ("undefined_b", np.float64), ("valid", bool))


@dataclass(frozen=True)
class Grid:
    """A regular grid of square cells in CRS coordinates, north up.

    ``x0, y0`` is the lower-left corner (multiples of ``size``), ``size`` the cell side in CRS
    units, ``rows x cols`` cells; raster row 0 is the northernmost row.
    """

    x0: float
    y0: float
    size: float
    rows: int
    cols: int

    @classmethod
    def covering(cls, xy, size):
        """The smallest grid aligned to multiples of ``size`` that holds every point of ``xy``
        (an (N, 2) array, or several stacked)."""
        lo, hi = xy.min(axis=0), xy.max(axis=0)
        corner = []
        for v in lo:
            c = math.floor(v / size) * size
            if math.floor((v - c) / size) < 0:  # round-off put the corner past the point
                c -= size
            corner.append(c)
        x0, y0 = corner
        # the arithmetic of cell_of, so that every point falls in a cell
        cols = int(math.floor((hi[0] - x0) / size)) + 1
        rows = int(math.floor((hi[1] - y0) / size)) + 1
        return cls(float(x0), float(y0), float(size), rows, cols)

    @property
    def n_cells(self):
        return self.rows * self.cols

    @property
    def transform(self):
        """Affine coefficients (a, b, c, d, e, f) from (col, row) to (x, y) of the raster's
        pixel corners: x = a col + b row + c, y = d col + e row + f (rasterio's order;
        GDAL's GetGeoTransform order is (c, a, b, f, d, e))."""
        return (self.size, 0.0, self.x0, 0.0, -self.size, self.y0 + self.rows * self.size)

    def cell_of(self, xy):
        """(N,) flat cell index (row-major, row 0 north) of each point, -1 outside the grid."""
        col = np.floor((xy[:, 0] - self.x0) / self.size).astype(np.int64)
        j = np.floor((xy[:, 1] - self.y0) / self.size).astype(np.int64)
        row = self.rows - 1 - j
        inside = (col >= 0) & (col < self.cols) & (row >= 0) & (row < self.rows)
        return np.where(inside, row * self.cols + col, -1)

    def bounds(self, flat):
        """(x_min, y_min, x_max, y_max) arrays of the cells ``flat``."""
        row, col = np.divmod(np.asarray(flat), self.cols)
        x_min = self.x0 + col * self.size
        y_min = self.y0 + (self.rows - 1 - row) * self.size
        return x_min, y_min, x_min + self.size, y_min + self.size


@dataclass
class Epoch:
    """One epoch of a change map: its name, cloud, per-point saliency (SPEC 1), the run's
    statistics and, once binned, the flat cell index of each point."""

    name: str
    cloud: object
    saliency: object
    metadata: dict = field(default_factory=dict)
    cells: np.ndarray = None


@dataclass
class ChangeMap:
    """The result of :func:`changes`.

    Attributes
    ----------
    table : numpy structured array
        One record per cell of the grid, row-major (row 0 north): ``row``, ``col``, cell bounds
        ``x_min, y_min, x_max, y_max`` (CRS coordinates), ``points_a``, ``points_b``,
        ``undefined_a``, ``undefined_b`` (share of the cell's points with undefined saliency),
        ``valid`` (both epochs hold ``min_points`` or more), the metrics of
        :data:`METRIC_KEYS` and ``score``; metrics are NaN where ``valid`` is False.
    classes_a, classes_b : (cells, C) int64
        Points of each class of ``class_table`` per cell, in each epoch.
    grid : Grid
    score : str
        The metric that ranks the cells (key of :data:`METRIC_KEYS`); the table's ``score`` holds
        its values, 1 - s_SSIM for ``"ssim"``, so that a larger score always means more change.
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
        return tuple(_cell_signature(e, np.flatnonzero(e.cells == flat), self.class_table, labelled, self.frame)
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
                "units": self.units.describe(), "crs": _crs_name(self.crs), "min_points": self.min_points,
                "score": self.score, "render": self.render, "frame_px": self.frame.size,
                "grid": {"rows": self.grid.rows, "cols": self.grid.cols, "transform": [a, b, c, d, e, f],
                         "cells": self.grid.n_cells, "valid": int(self.table["valid"].sum())},
                "method": self.method, "top": self.top(n)}

    def save(self, path, *, overwrite=False):
        """Write by extension: ``.tif``/``.tiff`` a GeoTIFF of every metric (needs rasterio:
        ``pip install lidar-sig[geo]``), ``.png`` the map, ``.html`` the report."""
        ext = Path(path).suffix.lower()
        if ext in (".tif", ".tiff"):
            from .io.geotiff import write_geotiff

            names = ("score",) + METRIC_KEYS + ("points_a", "points_b", "undefined_a", "undefined_b")
            bands = [self.raster(n) for n in names]
            for k, n in enumerate(names):  # counts and shares say nothing where a cell is empty
                if n.startswith("undefined"):
                    bands[k] = np.where(self.raster(n.replace("undefined", "points")) > 0, bands[k], np.nan)
            descriptions = [_band_description(n, self.score) for n in names]
            with step(f"writing {Path(path).name}", bands=len(names)):
                write_geotiff(path, bands, descriptions, self.grid.transform, self.crs, overwrite=overwrite)
        elif ext == ".png":
            from .render import write_png
            from .reporting.changes import change_map_image

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
        from .reporting.changes import changes_report

        return changes_report(self)


def _plain(value):
    value = float(value)
    return None if math.isnan(value) else value


def _crs_name(crs):
    if crs is None:
        return None
    import pyproj

    return pyproj.CRS.from_user_input(crs).name


def _band_description(name, score):
    from .metrics import METRICS

    names = {m.key: f"{m.name}: {m.short}" for m in METRICS}
    ranking = names[score].split(":")[0]
    text = {"score": f"score: {'1 - ' if score == 'ssim' else ''}{ranking}, the ranking metric",
            "points_a": "points of epoch A", "points_b": "points of epoch B",
            "undefined_a": "share of A's points with undefined saliency",
            "undefined_b": "share of B's points with undefined saliency"}
    return text.get(name) or names[name]


def read_epoch(source, *, columns=None):
    """A PointCloud from a file, a folder of tiles, a list of files, or a PointCloud.

    Tiles of one epoch are joined into one cloud (their saliency is then computed across tile
    edges); they must share one CRS and be all labelled or all unlabelled.
    """
    from .cloud import PointCloud
    from .io import CLOUD_EXTENSIONS, read

    if isinstance(source, PointCloud):
        return source
    if isinstance(source, (str, Path)) and Path(source).is_dir():
        paths = sorted(p for p in Path(source).iterdir() if p.suffix.lower() in CLOUD_EXTENSIONS)
        if not paths:
            raise LidarSigError(f"holds no point-cloud files ({', '.join(CLOUD_EXTENSIONS)})", path=source)
    elif isinstance(source, (list, tuple)):
        paths = list(source)
        if not paths:
            raise LidarSigError("an epoch given as a list needs at least one file")
    elif isinstance(source, (str, Path)):
        return read(source, columns=columns)
    else:
        raise LidarSigError(f"cannot read an epoch from a {type(source).__name__}; give a file, a folder of "
                            "tiles, a list of files or a PointCloud")
    clouds = [read(p, columns=columns) for p in paths]
    if len(clouds) == 1:
        return clouds[0]
    first = clouds[0]
    for c in clouds[1:]:
        if not same_crs(first.crs, c.crs):
            raise LidarSigError(f"is in another CRS than {first.path}; tiles of one epoch must share one CRS",
                                path=c.path)
        if (c.labels is None) != (first.labels is None):
            raise LidarSigError(f"has {'no ' if c.labels is None else ''}class labels unlike {first.path}; "
                                "give tiles of one epoch that are all labelled or all unlabelled", path=c.path)
    labels = None if first.labels is None else np.concatenate([c.labels for c in clouds])
    name = str(source) if not isinstance(source, (list, tuple)) else f"{first.path} (+{len(clouds) - 1} tiles)"
    return PointCloud(np.vstack([c.xyz for c in clouds]), labels, path=name, crs=first.crs, units=first.units)


def check_cell(cell):
    """The cell side as a float of metres, or LidarSigError naming the value."""
    if isinstance(cell, bool) or not isinstance(cell, (int, float, np.integer, np.floating)) \
            or not math.isfinite(cell) or cell <= 0:
        raise LidarSigError(f"the cell size must be a positive number of metres, got {cell!r}")
    return float(cell)


def changes(a, b, *, cell=CELL, pipeline=None, min_points=MIN_POINTS, score=None, render="smooth",
            frame=CELL_FRAME, columns=None):
    """Per-cell change map between two epochs of the same area (registration-free).

    Parameters
    ----------
    a, b : str, Path, list of paths, folder or PointCloud
        The two epochs: point-cloud files, folders of tiles or lists of tile files (joined into
        one cloud per epoch), or clouds. Both must be in the same CRS.
    cell : float
        Cell side in metres (converted to the CRS unit); default 25.
    pipeline : Pipeline, optional
        The method of the saliency; default ``Pipeline()`` (SPEC 1-4).
    min_points : int
        Fewest points of a cell in each epoch for it to be compared; default :data:`MIN_POINTS`.
    score : str, optional
        Metric that ranks the cells (a key of :data:`METRIC_KEYS`; for s_SSIM, 1 - SSIM ranks);
        default :data:`SCORE`, or :data:`GEOMETRIC_SCORE` when an epoch is unlabelled.
    render : str
        Rendering of Sg and Sas for the image metrics (see :mod:`lidar_sig.signature`).
    frame : Frame
        Frame of the per-cell signatures; default :data:`CELL_FRAME` (64 px).

    Returns
    -------
    ChangeMap
    """
    from .pipeline import Pipeline

    cell = check_cell(cell)
    min_points = whole_number(min_points, "min_points", low=1)
    if score is not None and score not in METRIC_KEYS:
        raise LidarSigError(f"unknown score {score!r}; use one of {', '.join(METRIC_KEYS)}")
    if pipeline is not None and not isinstance(pipeline, Pipeline):
        raise LidarSigError(f"pipeline must be a lidar_sig.Pipeline, got {pipeline!r}")
    pipeline = pipeline or Pipeline()
    clouds = [read_epoch(x, columns=columns) for x in (a, b)]
    names = [c.path or "(in memory)" for c in clouds]
    if (clouds[0].crs is None) != (clouds[1].crs is None):
        k = 0 if clouds[1].crs is None else 1  # the epoch that has one
        raise LidarSigError(f"{names[1 - k]} has no CRS while {names[k]} is in {_crs_name(clouds[k].crs)}; "
                            "give both epochs in one CRS")
    if not same_crs(clouds[0].crs, clouds[1].crs):
        raise LidarSigError(f"{names[0]} and {names[1]} are in different CRS ({_crs_name(clouds[0].crs)} / "
                            f"{_crs_name(clouds[1].crs)}); reproject one epoch into the other's CRS first")
    labelled = all(c.labels is not None for c in clouds)
    if not labelled and any(c.labels is not None for c in clouds):
        bare = names[0] if clouds[0].labels is None else names[1]
        warnings.warn(f"{bare} has no class labels: the cells are compared by geometry only (ranked by "
                      f"{score or GEOMETRIC_SCORE}) and both epochs' points are shown as one class", LidarSigWarning,
                      stacklevel=2)
    score = score or (SCORE if labelled else GEOMETRIC_SCORE)
    if score in ("kl", "l1") and not labelled:
        raise LidarSigError(f"score {score!r} needs class labels in both epochs; use emd_info or another "
                            "geometric metric")
    units = clouds[0].units
    grid = Grid.covering(np.vstack([c.xyz[:, :2] for c in clouds]), cell / units.horizontal)
    if grid.n_cells > MAX_CELLS:  # a far outlier, or a cell size meant in another unit
        raise LidarSigError(f"the epochs span {grid.cols:,} x {grid.rows:,} cells of {cell:g} m, more than "
                            f"{MAX_CELLS:,}; use a larger cell size (--cell) or remove far outlying points")
    filled = np.minimum(*(np.bincount(grid.cell_of(c.xyz[:, :2]), minlength=grid.n_cells) for c in clouds))
    if filled.max() < min_points:  # said before the saliency is computed
        raise LidarSigError(f"no cell of {cell:g} m holds {min_points:,} points in both epochs (at most "
                            f"{filled.max():,}); use a larger cell size (--cell) or a smaller minimum (--min-points)")
    epochs = []
    for cloud, name in zip(clouds, names):
        sal, stats = pipeline.saliency(cloud)
        epochs.append(Epoch(name, cloud, sal, stats))
    classes = pipeline.classes if labelled else _unlabelled()
    if not isinstance(frame, Frame):
        raise LidarSigError(f"frame must be a lidar_sig.Frame, got {frame!r}")
    with step("change map", cells=grid.n_cells, cell=f"{cell:g} m", frame=f"{frame.size} px") as s:
        out = cell_metrics(grid, epochs, classes, labelled, min_points=min_points, score=score, render=render,
                           frame=frame, progress=s)
    table, classes_a, classes_b = out
    method = {k: epochs[0].metadata[k] for k in ("descriptor", "strategy", "scale_kind", "scale_values",
                                                 "scale_units", "weights") if k in epochs[0].metadata}
    return ChangeMap(table, classes_a, classes_b, grid, clouds[0].crs, units, cell, int(min_points), score,
                     render, classes, epochs[0], epochs[1], frame, method)


def _unlabelled():
    from .classes import UNLABELED

    return UNLABELED


def cell_metrics(grid, epochs, classes, labelled, *, min_points=MIN_POINTS, score=SCORE, render="smooth",
                 frame=CELL_FRAME, progress=None):
    """The per-cell table and class counts of two epochs on ``grid`` (sets each epoch's ``cells``).

    Each epoch's points are binned by cell; a cell's signature is built from its points'
    saliency (computed on the whole epoch) in ``frame``, and every metric of
    :func:`lidar_sig.metrics.compare` is computed where both epochs hold ``min_points``.
    """
    from .metrics import compare

    n_cells, n_classes = grid.n_cells, len(classes)
    per_epoch = []
    for e in epochs:
        e.cells = grid.cell_of(e.cloud.xyz[:, :2])
        codes = e.cloud.labels if labelled else np.zeros(len(e.cloud), np.int64)
        index = classes.index(codes)
        order = np.argsort(e.cells, kind="stable")
        starts = np.searchsorted(e.cells[order], np.arange(n_cells + 1))
        counts = np.bincount(e.cells * n_classes + index, minlength=n_cells * n_classes)
        undefined = np.bincount(e.cells, weights=~e.saliency.defined, minlength=n_cells)
        per_epoch.append((order, starts, counts.reshape(n_cells, n_classes), undefined))
    dtype = list(CELL_FIELDS) + [(k, np.float64) for k in METRIC_KEYS] + [("score", np.float64)]
    table = np.zeros(n_cells, dtype=dtype)
    flat = np.arange(n_cells)
    table["row"], table["col"] = np.divmod(flat, grid.cols)
    table["x_min"], table["y_min"], table["x_max"], table["y_max"] = grid.bounds(flat)
    for tag, (_, starts, _, undefined) in zip("ab", per_epoch):
        n = np.diff(starts)
        table[f"points_{tag}"] = n
        table[f"undefined_{tag}"] = undefined / np.maximum(n, 1)
    table["valid"] = (table["points_a"] >= min_points) & (table["points_b"] >= min_points)
    for k in METRIC_KEYS + ("score",):
        table[k] = np.nan
    cells = np.flatnonzero(table["valid"])
    for c in (progress.track(cells, unit="cell") if progress is not None else cells):
        pair = [_cell_signature(e, order[starts[c]:starts[c + 1]], classes, labelled, frame)
                for e, (order, starts, _, _) in zip(epochs, per_epoch)]
        values = compare(*pair, render=render)
        for k in METRIC_KEYS:
            table[k][c] = np.nan if values[k] is None else values[k]
    table["score"] = 1.0 - table["ssim"] if score == "ssim" else table[score]
    return table, per_epoch[0][2], per_epoch[1][2]


def _cell_signature(epoch, idx, classes, labelled, frame):
    """Signature of the points ``idx`` of an epoch, from their saliency on the whole epoch."""
    codes = epoch.cloud.labels[idx] if labelled else np.zeros(len(idx), np.int64)
    sal = epoch.saliency
    return Signature.from_saliency(sal.values[idx], classes.index(codes), classes=classes, frame=frame,
                                   egeom=sal.egeom[idx])
