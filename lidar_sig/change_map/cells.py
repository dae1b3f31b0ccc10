"""Per-cell signatures and metrics of two epochs from their computed saliency: each epoch's
points binned by cell, a signature per cell built from its points' saliency (computed on the
whole epoch), and every metric of :func:`lidar_sig.metrics.compare` where both epochs hold
enough points. Nothing here runs a pipeline or ranks the cells."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..metrics import METRIC_KEYS, compare
from ..signature import Frame, Signature

#: Fewest points with defined saliency in a cell, in each epoch, for a signature worth comparing
#: (docs/changes.md).
MIN_POINTS = 1000
#: Frame of the per-cell signatures: 64 px (2 px margin) instead of 512 (docs/changes.md).
CELL_FRAME = Frame(64, 2)
#: Fields of the per-cell table besides the metrics (:data:`lidar_sig.metrics.METRIC_KEYS`) and
#: the score.
CELL_FIELDS = (("row", np.int32), ("col", np.int32), ("x_min", np.float64), ("y_min", np.float64),
               ("x_max", np.float64), ("y_max", np.float64), ("points_a", np.int64), ("points_b", np.int64),
               ("defined_a", np.int64), ("defined_b", np.int64), ("undefined_a", np.float64),
               ("undefined_b", np.float64), ("valid", bool))


@dataclass
class Binned:
    """An epoch's points by cell: ``order`` sorts them by cell, so that cell c holds the points
    ``order[starts[c]:starts[c + 1]]``; ``classes`` (cells, C) counts its points per class and
    ``undefined`` (cells,) those with undefined saliency."""

    order: np.ndarray
    starts: np.ndarray
    classes: np.ndarray
    undefined: np.ndarray

    def points(self, c):
        """Indices of the epoch's points in cell ``c``."""
        return self.order[self.starts[c]:self.starts[c + 1]]


def bin_points(epoch, grid, classes, labelled):
    """The :class:`Binned` points of ``epoch`` on ``grid`` (sets the epoch's ``cells``); class
    codes are indexed in ``classes``, all one class unless ``labelled``."""
    n_cells, n_classes = grid.n_cells, len(classes)
    epoch.cells = grid.cell_of(epoch.cloud.xyz[:, :2])
    codes = epoch.cloud.labels if labelled else np.zeros(len(epoch.cloud), np.int64)
    index = classes.index(codes)
    order = np.argsort(epoch.cells, kind="stable")
    starts = np.searchsorted(epoch.cells[order], np.arange(n_cells + 1))
    counts = np.bincount(epoch.cells * n_classes + index, minlength=n_cells * n_classes)
    undefined = np.bincount(epoch.cells[~epoch.saliency.defined], minlength=n_cells)
    return Binned(order, starts, counts.reshape(n_cells, n_classes), undefined)


def cell_signature(epoch, idx, classes, labelled, frame):
    """Signature of the points ``idx`` of an epoch, from their saliency on the whole epoch."""
    codes = epoch.cloud.labels[idx] if labelled else np.zeros(len(idx), np.int64)
    sal = epoch.saliency
    return Signature.from_saliency(sal.values[idx], classes.index(codes), classes=classes, frame=frame,
                                   egeom=sal.egeom[idx])


def cell_metrics(grid, epochs, classes, labelled, *, min_points=MIN_POINTS, render="smooth", frame=CELL_FRAME,
                 progress=None):
    """The per-cell table and class counts of two epochs on ``grid`` (sets each epoch's ``cells``).

    Each epoch's points are binned by cell; a cell's signature is built from its points'
    saliency (computed on the whole epoch) in ``frame``, and every metric of
    :func:`lidar_sig.metrics.compare` is computed where both epochs hold ``min_points`` points
    with defined saliency (the signatures leave the others out: a cell of points all undefined,
    e.g. spherical scales on a sparse cell, has no signature to compare). The
    table's ``score`` is left NaN for the ranking to fill
    (:func:`lidar_sig.change_map.result.score_values`). Returns ``(table, classes_a, classes_b)``.
    """
    binned = [bin_points(e, grid, classes, labelled) for e in epochs]
    n_cells = grid.n_cells
    dtype = list(CELL_FIELDS) + [(k, np.float64) for k in METRIC_KEYS] + [("score", np.float64)]
    table = np.zeros(n_cells, dtype=dtype)
    flat = np.arange(n_cells)
    table["row"], table["col"] = np.divmod(flat, grid.cols)
    table["x_min"], table["y_min"], table["x_max"], table["y_max"] = grid.bounds(flat)
    for tag, b in zip("ab", binned):
        n = np.diff(b.starts)
        table[f"points_{tag}"] = n
        table[f"defined_{tag}"] = n - b.undefined
        table[f"undefined_{tag}"] = b.undefined / np.maximum(n, 1)
    table["valid"] = (table["defined_a"] >= min_points) & (table["defined_b"] >= min_points)
    for k in METRIC_KEYS + ("score",):
        table[k] = np.nan
    cells = np.flatnonzero(table["valid"])
    for c in (progress.track(cells, unit="cell") if progress is not None else cells):
        pair = [cell_signature(e, b.points(c), classes, labelled, frame) for e, b in zip(epochs, binned)]
        values = compare(*pair, render=render)
        for k in METRIC_KEYS:
            table[k][c] = np.nan if values[k] is None else values[k]
    return table, binned[0].classes, binned[1].classes
