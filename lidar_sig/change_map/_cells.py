"""Per-cell signatures and metrics of two epochs from their computed saliency: each epoch's
points binned by cell and coded once (their pixel in the cell frame, Egeom bin and class), a
signature per cell built from its points' codes, every metric of
:func:`lidar_sig.metrics.compare` where both epochs hold enough points, and the same metrics
between resamples of one epoch's points (the sampling part of the level of detection,
:mod:`~lidar_sig.change_map._lod`). Nothing here runs a pipeline or ranks the cells."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..metrics import METRIC_KEYS, compare
from ..numerics.hashing import below_share, hash2, mix64
from ..numerics.sorting import stable_order
from ..method.signature_raster import Frame, Signature, point_codes
from ._heights import HEIGHT, height_distance
from ._lod import REPLICATES

#: Frame of the per-cell signatures: 64 px (2 px margin) instead of 512 (docs/changes.md).
CELL_FRAME = Frame(64, 2)
#: Seed of the resampling; each cell draws from its own stream (seed, interval, cell), so that
#: the draws do not depend on the order in which cells are processed.
SEED = 17
#: What the change map compares per cell: every metric of the signatures
#: (:data:`lidar_sig.metrics.METRIC_KEYS`) and the height component delta_H (:mod:`.heights`).
CHANGE_KEYS = METRIC_KEYS + (HEIGHT,)
#: Fields of the per-cell table besides the compared values (:data:`CHANGE_KEYS`) and the
#: ranking fields (:data:`RANKING_FIELDS`).
CELL_FIELDS = (("row", np.int32), ("col", np.int32), ("x_min", np.float64), ("y_min", np.float64),
               ("x_max", np.float64), ("y_max", np.float64), ("points_a", np.int64), ("points_b", np.int64),
               ("defined_a", np.int64), ("defined_b", np.int64), ("undefined_a", np.float64),
               ("undefined_b", np.float64), ("valid", bool), ("coverage", np.int8), ("in_footprint", bool))
#: The coverage states of a cell (the table's ``coverage``, the GeoTIFF's band), by code:
#: compared (both epochs hold the fewest points), appeared (only the later epoch covers it),
#: vanished (only the earlier), too few points (points of either or both, not enough to
#: compare), not covered (no point of either).
COVERAGE = {1: "compared", 2: "appeared", 3: "vanished", 4: "too few points", 0: "not covered"}
#: The coverage codes that are change where the other epoch's survey covers the cell
#: (:func:`in_footprint`): appeared and vanished.
COVERAGE_CHANGES = (2, 3)
#: The largest hole in a survey's footprint (m²) whose cells count as its land: a hectare, some
#: blocks of buildings or a quarry's pit. Larger holes are gaps in the survey (a 1 km tile missing
#: from a delivery is 100 ha), and their appeared or vanished cells are not counted as change.
HOLE_M2 = 10_000.0
#: Only one epoch covers a cell where it holds this share of the fewest points or more (a tenth of
#: a full cell with the automatic minimum: the sliver of points that a shift of a few decimetres
#: moves across a survey's edge, 1.2% of a full 25 m cell for 0.3 m, does not) ...
COVERS = 0.5
#: ... and the other epoch holds less than this share of as many points per m² (its points
#: divided by its density, so that a sparser survey does not look absent).
ALMOST_NONE = 0.1
#: The ranking's fields, filled by the ranking: the score, its level of detection, delta_H's
#: level, z (the larger of the two tests'), how far the cell lies from its levels (lod_ratio)
#: and the significance.
RANKING_FIELDS = (("score", np.float64), ("lod", np.float64), ("height_lod", np.float64), ("z", np.float64),
                  ("lod_ratio", np.float64), ("significant", bool), ("p", np.float64), ("q", np.float64),
                  ("changed", bool))


@dataclass
class Binned:
    """An epoch's points by cell: ``order`` sorts them by cell, so that cell c holds the points
    ``order[starts[c]:starts[c + 1]]``; ``classes`` (cells, C) counts its points per class and
    ``undefined`` (cells,) those with undefined saliency; ``pixel``, ``egeom_bin`` and
    ``class_index`` (N,) code each point for a signature (:func:`lidar_sig.method.signature_raster.point_codes`);
    ``height`` (N,) is each point's z in metres (:mod:`.heights`); ``keys`` (N,) each point's
    :func:`point_keys`, which order a cell's points (None: ``order`` does already)."""

    order: np.ndarray
    starts: np.ndarray
    classes: np.ndarray
    undefined: np.ndarray
    pixel: np.ndarray
    egeom_bin: np.ndarray
    class_index: np.ndarray
    height: np.ndarray
    keys: np.ndarray | None = None

    def points(self, c):
        """Indices of the epoch's points in cell ``c``, ordered by their :func:`point_keys`: the
        order the resamples draw from, whatever the order of the points in their files."""
        idx = self.order[self.starts[c]:self.starts[c + 1]]
        return idx if self.keys is None else idx[np.argsort(self.keys[idx], kind="stable")]

    def signature(self, idx, classes, frame):
        """The signature of the epoch's points ``idx`` (repeats allowed: a resample)."""
        return Signature.from_codes(self.pixel[idx], self.egeom_bin[idx], self.class_index[idx], classes=classes,
                                    frame=frame)


#: Coordinates are rounded to this step of the CRS unit (0.1 mm in metres) before they key a point
#: (:func:`point_keys`): the same point read from files cut on other grids, with other offsets,
#: may differ in its last bits, never by this much (surveys store centimetres or millimetres).
KEY_STEP = 1e-4


def point_keys(xyz, labels=None):
    """(N,) uint64 key of each point from its coordinates (CRS units, rounded to
    :data:`KEY_STEP`) and class code (None: all 0): the order of a cell's points for its resamples, so that the map is a function of the points,
    not of the files that carry them nor of their order in them (docs/changes.md, "The level of
    detection"). Points with equal keys are the same point (up to a hash collision, about one in
    2^64 per pair): their order among themselves changes nothing."""
    q = np.rint(np.asarray(xyz, dtype=np.float64) / KEY_STEP).astype(np.int64).view(np.uint64)
    with np.errstate(over="ignore"):
        key = hash2(q[:, 0], q[:, 1])
        key = mix64(key ^ q[:, 2])
        if labels is not None:  # an unlabelled cloud's points are class 0, as its staged records are
            key ^= np.asarray(labels).astype(np.int64).view(np.uint64)
        return mix64(key)


@dataclass(frozen=True)
class Sample:
    """The sample of an epoch's points whose saliency a change map computes and whose cells'
    signatures take them (:func:`in_sample` of share ``fraction``): small, sent to the tiles of
    a run in work units (a fraction of 1: every point). Its tiles keep the sample's points
    coded for the cells (:data:`lidar_sig.tiling._tasks.SAMPLE_POINTS`), keys included."""

    fraction: float

    @staticmethod
    def keys(xyz, labels):
        """(N,) :func:`point_keys` of the points of coordinates ``xyz`` (N, 3, CRS units) and class codes."""
        return point_keys(xyz, labels)

    def mask(self, xyz, labels, keys=None):
        """(N,) bool: the points of coordinates ``xyz`` (N, 3, CRS units) and class codes in the
        sample (``keys``: their :meth:`keys`, when computed already)."""
        inside = in_sample(xyz, labels, self.fraction, keys)
        return np.ones(len(xyz), bool) if inside is None else inside


def in_sample(xyz, labels, fraction, keys=None):
    """(N,) bool: the points of an epoch's sample of share ``fraction`` (:func:`sample_fraction
    <lidar_sig.change_map._density.sample_fraction>`), those whose :func:`point_keys` (``keys``
    when computed already) lie in the lowest ``fraction`` of their range: the same points however
    the epoch is ordered, cut or listed; None for a fraction of 1 (every point)."""
    if fraction >= 1.0:
        return None
    keys = point_keys(xyz, labels) if keys is None else keys
    return below_share(keys, fraction)


def epoch_cells(epoch, grid):
    """(N,) flat cell index of each point of ``epoch`` on ``grid``; points the run left out
    (withheld and noise, ``epoch.kept``) are in no cell: their index is ``grid.n_cells``."""
    cells = grid.cell_of(epoch.cloud.xyz[:, :2])
    return cells if epoch.kept is None else np.where(epoch.kept, cells, grid.n_cells)


def bin_points(epoch, grid, classes, labelled, frame=CELL_FRAME):
    """The :class:`Binned` points of ``epoch`` on ``grid``; class codes are indexed in
    ``classes``, all one class unless ``labelled``. Points the run left out are in no cell
    (:func:`epoch_cells`)."""
    n_cells, n_classes = grid.n_cells, len(classes)
    cells = epoch_cells(epoch, grid)
    codes = epoch.cloud.labels if labelled else np.zeros(len(epoch.cloud), np.int64)
    index = classes.index(codes)
    order = stable_order(cells)
    starts = np.searchsorted(cells[order], np.arange(n_cells + 1))
    counts = np.bincount(cells * n_classes + index, minlength=(n_cells + 1) * n_classes)[:n_cells * n_classes]
    undefined = np.bincount(cells[~epoch.saliency.defined], minlength=n_cells + 1)[:n_cells]
    pixel, egeom_bin = point_codes(epoch.saliency.values, index, frame, egeom=epoch.saliency.egeom)
    height = epoch.cloud.xyz[:, 2] * epoch.cloud.units.vertical
    keys = epoch.keys if epoch.keys is not None else point_keys(epoch.cloud.xyz, epoch.cloud.labels)
    return Binned(order, starts, counts.reshape(n_cells, n_classes), undefined, pixel, egeom_bin, index, height, keys)


def cell_signature(epoch, idx, classes, labelled, frame):
    """Signature of the points ``idx`` of an epoch, from their saliency on the whole epoch."""
    codes = epoch.cloud.labels[idx] if labelled else np.zeros(len(idx), np.int64)
    sal = epoch.saliency
    return Signature.from_saliency(sal.values[idx], classes.index(codes), classes=classes, frame=frame,
                                   egeom=sal.egeom[idx])


def cell_table(grid, binned, min_points, densities=(1.0, 1.0), cell_m=None):
    """The per-cell table of two binned epochs: bounds, counts and ``valid`` (both epochs hold
    ``min_points`` points with defined saliency: the signatures leave the others out, and a cell
    of points all undefined, e.g. spherical scales on a sparse cell, has no signature to
    compare), ``coverage`` (:func:`coverage`, with the epochs' ``densities`` in points per m²);
    the metrics and ranking fields NaN (False) for :func:`observed_metrics` and the ranking to
    fill."""
    return counts_table(grid, [np.diff(b.starts) for b in binned], [b.undefined for b in binned], min_points,
                        densities, cell_m)


def counts_table(grid, points, undefined, min_points, densities=(1.0, 1.0), cell_m=None):
    """:func:`cell_table` from each epoch's points and undefined points per cell ((cells,)
    arrays), as a survey-scale map gathers them from its work units."""
    n_cells = grid.n_cells
    dtype = list(CELL_FIELDS) + [(k, np.float64) for k in CHANGE_KEYS] + list(RANKING_FIELDS)
    table = np.zeros(n_cells, dtype=dtype)
    flat = np.arange(n_cells)
    table["row"], table["col"] = np.divmod(flat, grid.cols)
    table["x_min"], table["y_min"], table["x_max"], table["y_max"] = grid.bounds(flat)
    for tag, n, u in zip("ab", points, undefined):
        table[f"points_{tag}"] = n
        table[f"defined_{tag}"] = n - u
        table[f"undefined_{tag}"] = u / np.maximum(n, 1)
    table["valid"] = (table["defined_a"] >= min_points) & (table["defined_b"] >= min_points)
    table["coverage"] = coverage(table["points_a"], table["points_b"], table["valid"], min_points, densities)
    table["in_footprint"] = in_footprint(table["coverage"], table["points_a"], table["points_b"], min_points,
                                         (grid.rows, grid.cols), cell_m)
    for k in CHANGE_KEYS + ("score", "lod", "height_lod", "z", "lod_ratio", "p", "q"):
        table[k] = np.nan
    return table


def covering(min_points):
    """The points from which one epoch covers a cell: :data:`COVERS` x ``min_points``, at least one."""
    return max(1, int(np.ceil(COVERS * min_points)))


def coverage(points_a, points_b, valid, min_points, densities=(1.0, 1.0)):
    """(cells,) int8 :data:`COVERAGE` code of each cell from its points in each epoch, whether it
    is compared and the epochs' ``densities``: appeared where B holds :data:`COVERS` x
    ``min_points`` points or more (at least one) and A, per unit of its density, less than
    :data:`ALMOST_NONE` of B's; vanished the other way round; too few points where either holds
    a point; not covered where neither does."""
    least = covering(min_points)
    points_a, points_b = np.asarray(points_a), np.asarray(points_b)
    per_a, per_b = points_a / densities[0], points_b / densities[1]  # points as if at one density
    appeared = (points_b >= least) & (per_a < ALMOST_NONE * per_b)
    vanished = (points_a >= least) & (per_b < ALMOST_NONE * per_a)
    code = np.select([valid, appeared, vanished, (points_a > 0) | (points_b > 0)], [1, 2, 3, 4], 0)
    return code.astype(np.int8)


def footprint(present, most_cells=None):
    """(rows, cols) bool: the land an epoch surveyed, from the cells where it holds points
    (``present``, (rows, cols) bool): those cells and the holes they enclose. A hole is a set of
    cells without its points that no path of such cells, edge or corner, joins to the grid's
    border (a bay whose mouth is one diagonal step is open); with ``most_cells``, only holes of
    at most that many cells: a larger one is a gap in the survey (a tile missing from a
    delivery, a strip not flown), not land that changed."""
    from scipy.ndimage import binary_fill_holes, label

    around = np.ones((3, 3), bool)  # the outside reaches a hole through corners too
    filled = binary_fill_holes(present, structure=around)
    if most_cells is None:
        return filled
    holes, n = label(filled & ~present, structure=around)
    sizes = np.bincount(holes.ravel(), minlength=n + 1)
    small = sizes <= most_cells
    small[0] = False
    return present | small[holes]


def in_footprint(codes, points_a, points_b, min_points, shape, cell_m=None):
    """(cells,) bool: the appeared cells inside A's :func:`footprint` and the vanished cells
    inside B's: land the other survey covered around them but found no points on (a building
    raised on water, a roof removed from the ground's survey), not the edge of a survey that did
    not reach so far, nor a gap in it larger than :data:`HOLE_M2` (with ``cell_m``, the cell's
    side in metres). An epoch is present in a cell where it holds :data:`COVERS` x
    ``min_points`` points or more and the cell is not named as only the other's (a cell at the
    edge of A's survey, holding a sliver of its points, is not A's land); False for every other
    coverage state."""
    least = covering(min_points)
    most = None if cell_m is None else max(1, int(HOLE_M2 // (cell_m * cell_m)))
    codes = np.asarray(codes)
    inside = np.zeros(len(codes), bool)
    for code, points in ((2, points_a), (3, points_b)):
        mine = codes == code
        if mine.any():
            present = (np.asarray(points) >= least) & ~mine
            surveyed = footprint(present.reshape(shape), most).ravel()
            inside |= mine & surveyed
    return inside


def observed_metrics(table, binned, classes, *, render="smooth", frame=CELL_FRAME, progress=None):
    """Fill the table's metrics: every metric of :func:`lidar_sig.metrics.compare` between the
    two epochs' signatures of each valid cell (NaN where a metric is undefined), and delta_H
    between their heights (:func:`cell_observed`)."""
    cells = np.flatnonzero(table["valid"])
    for c in (progress.track(cells, unit="cell") if progress is not None else cells):
        for k, v in zip(CHANGE_KEYS, cell_observed(binned, c, classes, render, frame)):
            table[k][c] = v


def cell_observed(binned, c, classes, render="smooth", frame=CELL_FRAME):
    """The values of :data:`CHANGE_KEYS` between the two epochs' points of cell ``c``."""
    idx = [b.points(c) for b in binned]
    return _compared(*(b.signature(i, classes, frame) for b, i in zip(binned, idx)),
                     *(b.height[i] for b, i in zip(binned, idx)), render)


def _compared(sig_a, sig_b, z_a, z_b, render):
    """The values of :data:`CHANGE_KEYS` between two cells' signatures and heights, NaN where a
    metric is undefined."""
    values = compare(sig_a, sig_b, render=render)
    return [np.nan if values[k] is None else values[k] for k in METRIC_KEYS] + [height_distance(z_a, z_b)]


def null_metrics(table, binned, classes, *, replicates=REPLICATES, render="smooth", frame=CELL_FRAME, seed=SEED,
                 stream=0, progress=None, flat=None):
    """(cells, 2 x replicates, :data:`CHANGE_KEYS`) values of every metric between resamples of one
    epoch's points, NaN outside the valid cells (:func:`cell_replicates`); the random stream
    of row c is that of flat cell ``flat[c]`` of the map's grid (a work unit's rows,
    :mod:`~lidar_sig.change_map._units`), else of cell c."""
    out = np.full((len(table), 2 * replicates, len(CHANGE_KEYS)), np.nan)
    cells = np.flatnonzero(table["valid"])
    for c in (progress.track(cells, unit="cell") if progress is not None else cells):
        sizes = (int(table["points_a"][c]), int(table["points_b"][c]))
        out[c] = cell_replicates(binned, c, sizes, classes, replicates=replicates, render=render, frame=frame,
                                 seed=seed, stream=stream, flat=int(c if flat is None else flat[c]))
    return out


def cell_replicates(binned, c, sizes, classes, *, replicates=REPLICATES, render="smooth", frame=CELL_FRAME,
                    seed=SEED, stream=0, flat=None):
    """(2 x replicates, :data:`CHANGE_KEYS`) values between resamples of one epoch's points of
    cell ``c``: for each epoch and replicate, the cell's points of that epoch drawn with
    replacement at the two epochs' counts ``sizes`` (undefined points included, as the class
    totals count them) and compared (NaN where a resample holds no defined point). What
    unchanged land gives, sampled as this cell is: the sampling part of the level of
    detection. The draws come from the random stream (``seed``, ``stream``, ``flat``), ``flat``
    the cell's flat index on the map's grid (default ``c``), whatever the process or unit."""
    rng = np.random.default_rng([seed, stream, int(c if flat is None else flat)])
    out = np.full((2 * replicates, len(CHANGE_KEYS)), np.nan)
    j = 0
    for b in binned:
        idx = b.points(c)
        for _ in range(replicates):
            draws = [idx[rng.integers(0, len(idx), m)] for m in sizes]
            pair = [b.signature(d, classes, frame) for d in draws]
            if all(s.n_points for s in pair):  # a resample of defined points only, all but surely
                out[j] = _compared(*pair, *(b.height[d] for d in draws), render)
            j += 1
    return out
