"""Where did it change? A registration-free change map: per-cell signature distances, and a level
of detection per cell that says which cells changed significantly.

The paper compares two clouds as wholes and names the price: the signature "does not preserve
the spatial contextual information" (Sreevalsan-Nair & Mohapatra, Sec. 6). Signatures are
additive count rasters (docs/method.md, "Signatures"), so a regular grid of cells in the survey's CRS gives one
signature per cell per epoch from the per-point saliency, with no point-to-point matching: a
shift of a few decimetres between the epochs moves a few points across a cell edge, nothing more.

- Saliency is computed on each WHOLE epoch (so that cell edges do not cut neighbourhoods), once
  per epoch, then the points are binned into cells. An epoch denser than
  :data:`SAMPLE_DENSITY` points per m² (more for cells under 25 m, :data:`SAMPLE_CELL_POINTS`
  a cell) is sampled by its points' keys: the cells take the sample, its saliency alone is
  computed, the neighbours among all the points.
- Cells are squares of ``cell`` metres, aligned to multiples of the cell size in the CRS's
  coordinates (converted to the CRS unit), so that grids of different runs agree. A cell is
  half-open: [x0 + i s, x0 + (i + 1) s) x [y0 + j s, y0 + (j + 1) s). By default the cell and
  the fewest points per cell are chosen from the epochs' densities (:mod:`.density`).
- A cell where either epoch holds fewer than ``min_points`` points with defined saliency is not
  compared; its coverage state says why (appeared, vanished, too few points, not covered).
- Per-cell signatures use a :data:`CELL_FRAME` of 64 px instead of 512 (docs/changes.md), and
  one more augmentation, the height component delta_H (:mod:`.heights`).
- Every metric gets a level of detection per cell (:mod:`.lod`): resamples of each epoch's
  points for the sampling part, the spread over all cells for what differs between the surveys.
- A cell changed significantly when its score, :data:`SCORE` (delta_KL) or
  :data:`LABEL_FREE_SCORE` (delta_FV) where the labels cannot say (unlabelled epochs, class
  schemes that barely overlap), or its delta_H exceeds its level, the two tests together at
  the map's confidence; significant cells first, then by lod_ratio (the map's colour).

The modules: :mod:`~lidar_sig.change_map._grid` (the cells), :mod:`~lidar_sig.change_map._density`
(the defaults from the densities), :mod:`~lidar_sig.change_map._epochs` (an epoch read, joined
from tiles, checked against the others), :mod:`~lidar_sig.change_map._cells` (per-cell
signatures, metrics and resampled metrics from computed saliency, coverage states),
:mod:`~lidar_sig.change_map._heights` (delta_H), :mod:`~lidar_sig.change_map._lod`
(the level of detection, array in, array out), :mod:`~lidar_sig.change_map._maps` (the
ChangeMap: levels, ranking, rasters, files), :mod:`~lidar_sig.change_map.series` (more than two
epochs) and :mod:`~lidar_sig.change_map._compute` (:func:`changes`, which reads the epochs and runs
the pipeline).
"""
from ._cells import (CELL_FIELDS, CELL_FRAME, SEED, Sample, bin_points, cell_signature, in_sample, null_metrics,
                     observed_metrics)
from ._density import SAMPLE_CELL_POINTS, SAMPLE_DENSITY, auto_cell, auto_min_points, density, sample_fraction
from ._epochs import Epoch, compute_epoch, read_epoch
from ._grid import MAX_CELLS, Grid, check_cell
from ._lod import CONFIDENCE, REPLICATES, Level, level_of_detection
from ._maps import LABEL_FREE_SCORE, SCORE, ChangeMap, metric_levels, score_values
from ._compute import AUTO, changes
from ._in_units import TiledEpoch, check_streamed, in_units
from .series import ChangeSeries

__all__ = ["AUTO", "CELL_FIELDS", "CELL_FRAME", "CONFIDENCE", "LABEL_FREE_SCORE", "MAX_CELLS", "REPLICATES",
           "SAMPLE_CELL_POINTS", "SAMPLE_DENSITY", "SCORE", "SEED", "Sample", "ChangeMap", "ChangeSeries", "Epoch", "Grid", "Level", "TiledEpoch", "auto_cell", "auto_min_points",
           "bin_points", "cell_signature", "changes", "check_cell", "check_streamed", "compute_epoch", "density", "in_sample", "in_units", "level_of_detection",
           "metric_levels",
           "null_metrics", "observed_metrics", "read_epoch", "sample_fraction", "score_values"]
