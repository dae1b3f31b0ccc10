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

The modules: :mod:`~lidar_sig.change_map.grid` (the cells), :mod:`~lidar_sig.change_map.epochs`
(an epoch read, joined from tiles, checked against the other), :mod:`~lidar_sig.change_map.cells`
(per-cell signatures and metrics from computed saliency), :mod:`~lidar_sig.change_map.result`
(the ChangeMap: ranking, rasters, files) and :mod:`~lidar_sig.change_map.run` (:func:`changes`,
which reads the epochs and runs the pipeline).
"""
from .cells import CELL_FIELDS, CELL_FRAME, MIN_POINTS, bin_points, cell_metrics, cell_signature
from .epochs import Epoch, read_epoch
from .grid import CELL, MAX_CELLS, Grid, check_cell
from .result import GEOMETRIC_SCORE, SCORE, THRESHOLDS, ChangeMap, score_values
from .run import changes

__all__ = ["CELL", "CELL_FIELDS", "CELL_FRAME", "GEOMETRIC_SCORE", "MAX_CELLS", "MIN_POINTS", "SCORE", "THRESHOLDS",
           "ChangeMap", "Epoch", "Grid", "bin_points", "cell_metrics", "cell_signature", "changes", "check_cell",
           "read_epoch", "score_values"]
