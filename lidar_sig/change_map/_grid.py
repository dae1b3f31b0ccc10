"""The change map's grid: square cells in CRS coordinates, aligned to multiples of the cell size,
north up; which cell holds each point, and each cell's bounds."""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..base.errors import positive_metres
from ..numerics.bounds import bounds

#: Most cells a change map holds (its table takes about 200 bytes a cell).
MAX_CELLS = 4_000_000


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
        lo, hi = bounds(xy)
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


def check_cells(grid, cell):
    """Refuse a grid of more than :data:`MAX_CELLS` cells of ``cell`` metres (a far outlier, or a
    cell size meant in another unit)."""
    from ..base.errors import LidarSigError, amount

    if grid.n_cells > MAX_CELLS:
        raise LidarSigError(f"the epochs span {amount(grid.cols)} x {amount(grid.rows)} cells of {cell:g} m, more than "
                            f"{MAX_CELLS:,}; use a larger cell size (--cell) or remove far outlying points")


def check_overlap(xy_a, xy_b, name_a, name_b):
    """A LidarSigError when the extents of two epochs' (N, 2) points (or their corners) are
    disjoint: they share no land to compare."""
    from ..base.errors import LidarSigError

    (low_a, high_a), (low_b, high_b) = bounds(xy_a), bounds(xy_b)
    if np.any(high_a < low_b) or np.any(high_b < low_a):
        def extent(low, high):
            return f"x {low[0]:.1f} to {high[0]:.1f}, y {low[1]:.1f} to {high[1]:.1f}"

        raise LidarSigError(f"{name_a} ({extent(low_a, high_a)}) and {name_b} ({extent(low_b, high_b)}) do not "
                            "overlap; give epochs of the same area")


def check_span(corners, size, cell):
    """Refuse, before the grid is made, epochs whose extent (the (N, 2) ``corners``, from their
    headers or points) spans more than :data:`MAX_CELLS` cells of ``size`` CRS units (``cell``
    metres): counted in floats, which a cell of 1e-300 m takes (the grid's whole numbers do not)."""
    from ..base.errors import LidarSigError, amount

    lo, hi = bounds(np.asarray(corners, float))
    with np.errstate(over="ignore", invalid="ignore"):
        spans = (hi - lo) / size
        cells = float(np.prod(np.maximum(spans, 1.0)))
    if not np.all(np.isfinite(spans)) or cells > MAX_CELLS:
        shown = [amount(math.ceil(v)) if np.isfinite(v) else "more than 1e+308" for v in spans]
        raise LidarSigError(f"the epochs span {shown[0]} x {shown[1]} cells of {cell:g} m, more than {MAX_CELLS:,}; "
                            "use a larger cell size (--cell) or remove far outlying points")


#: Largest cell side in metres (1,000 km: more than any survey in one projected CRS; a cell's
#: area and its fewest points must stay numbers).
MAX_CELL = 1e6


def check_cell(cell):
    """The cell side as a float of metres, or LidarSigError naming the value."""
    from ..base.errors import LidarSigError

    cell = positive_metres(cell, "the cell size")
    if cell > MAX_CELL:
        raise LidarSigError(f"the cell size must be at most {MAX_CELL:g} m (1,000 km), got {cell:g}; give the cell "
                            "side in metres, e.g. --cell 10")
    return cell
