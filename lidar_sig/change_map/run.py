"""The change map of two epochs from their files (:func:`changes`, `lidar-sig changes`): read
both epochs, check them, compute each one's saliency with the pipeline, then the cells' metrics
and their ranking."""
from __future__ import annotations

import warnings

import numpy as np

from ..classes import UNLABELED
from ..errors import LidarSigError, LidarSigWarning, whole_number
from ..metrics import METRIC_KEYS
from ..progress import step
from ..signature import Frame
from .cells import CELL_FRAME, MIN_POINTS, cell_metrics
from .epochs import Epoch, check_same_crs, read_epoch
from .grid import CELL, MAX_CELLS, Grid, check_cell
from .result import GEOMETRIC_SCORE, SCORE, ChangeMap, score_values


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
        Fewest points of a cell in each epoch for it to be compared; default
        :data:`~lidar_sig.change_map.MIN_POINTS`.
    score : str, optional
        Metric that ranks the cells (a key of :data:`lidar_sig.metrics.METRIC_KEYS`; for
        s_SSIM, 1 - SSIM ranks); default :data:`~lidar_sig.change_map.SCORE`, or
        :data:`~lidar_sig.change_map.GEOMETRIC_SCORE` when an epoch is unlabelled.
    render : str
        Rendering of Sg and Sas for the image metrics (see :mod:`lidar_sig.signature`).
    frame : Frame
        Frame of the per-cell signatures; default :data:`~lidar_sig.change_map.CELL_FRAME` (64 px).

    Returns
    -------
    ChangeMap
    """
    from ..pipeline import Pipeline

    cell = check_cell(cell)
    min_points = whole_number(min_points, "min_points", low=1)
    if score is not None and score not in METRIC_KEYS:
        raise LidarSigError(f"unknown score {score!r}; use one of {', '.join(METRIC_KEYS)}")
    if pipeline is not None and not isinstance(pipeline, Pipeline):
        raise LidarSigError(f"pipeline must be a lidar_sig.Pipeline, got {pipeline!r}")
    pipeline = pipeline or Pipeline()
    clouds = [read_epoch(x, columns=columns) for x in (a, b)]
    names = [c.path or "(in memory)" for c in clouds]
    check_same_crs(clouds, names)
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
    classes = pipeline.classes if labelled else UNLABELED
    if not isinstance(frame, Frame):
        raise LidarSigError(f"frame must be a lidar_sig.Frame, got {frame!r}")
    with step("change map", cells=grid.n_cells, cell=f"{cell:g} m", frame=f"{frame.size} px") as s:
        table, classes_a, classes_b = cell_metrics(grid, epochs, classes, labelled, min_points=min_points,
                                                   render=render, frame=frame, progress=s)
    if not table["valid"].any():  # the points are there, their saliency is not
        raise LidarSigError(f"no cell of {cell:g} m holds {min_points:,} points with defined saliency in both "
                            f"epochs (at most {int(np.minimum(table['defined_a'], table['defined_b']).max()):,}); "
                            "use a larger cell size (--cell), a smaller minimum (--min-points) or larger scales")
    table["score"] = score_values(table, score)
    method = {k: epochs[0].metadata[k] for k in ("descriptor", "strategy", "scale_kind", "scale_values",
                                                 "scale_units", "weights") if k in epochs[0].metadata}
    return ChangeMap(table, classes_a, classes_b, grid, clouds[0].crs, units, cell, int(min_points), score,
                     render, classes, epochs[0], epochs[1], frame, method)
