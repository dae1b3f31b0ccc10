"""PointCloud: coordinates, optional semantic labels and the source file's own record."""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..numerics.bounds import bounds
from .crs import Units, units_of
from ..base.errors import LidarSigError, counted

#: Largest coordinate accepted, in metres (after the CRS's unit): 1e9 m. Real coordinates stay
#: far below it (geocentric ECEF up to 6.4e6 m, UTM northings up to 1e7 m, national grids
#: alike); at 1e9 m float64 still resolves 1.2e-7 m (2**-23), four orders below the millimetre
#: of the closest neighbours, and the voxel indices of the neighbour search (extent / voxel
#: side) stay far inside int64. Beyond it the precision goes (at 1e16 m points 1 m apart are
#: one location), and a LAS file could not hold such a cloud in its 32-bit integers either.
MAX_COORDINATE = 1e9


@dataclass(repr=False)
class PointCloud:
    """N points x_i in R^3 (metres or any linear unit, z up).

    Attributes
    ----------
    xyz : (N, 3) float64 array
        Coordinates as stored in the file (scaled and offset for LAS).
    labels : (N,) int array or None
        Semantic class code per point (ASPRS codes for LAS), None when unlabeled.
    source : object or None
        The reader's full record of the file (``laspy.LasData`` for LAS/LAZ), kept so that
        writers can return every original dimension and VLR unchanged.
    path : str or None
        Where the cloud was read from, for messages and metadata.
    attributes : dict
        Other per-point values by name, (N,) or (N, k) arrays: intensity, colours, normals...
    previous_outputs : tuple of str
        Names among the file's attributes (or LAS extra dimensions) that an earlier lidar_sig
        run wrote; writers replace them instead of treating them as the user's own.
    crs : str or None
        Coordinate reference system (WKT, or any text pyproj reads, e.g. ``"EPSG:2154"``);
        None when unknown.
    units : Units or None
        Metres per coordinate unit (see :mod:`lidar_sig.method.crs`); derived from ``crs`` when not
        given, metres assumed when the CRS is unknown.
    withheld : (N,) bool array or None
        The LAS "withheld" flag of each point (points to be left out, ASPRS), None when no
        point has it (other formats have no such flag). A run leaves them out unless
        ``keep_noise`` (:func:`kept_points`).
    """

    xyz: np.ndarray
    labels: np.ndarray | None = None
    source: Any = None
    path: str | None = None
    attributes: dict = field(default_factory=dict)
    previous_outputs: tuple = ()
    crs: str | None = None
    units: Units | None = None
    withheld: np.ndarray | None = None

    def __repr__(self):
        from .crs import crs_name
        from ..base.views import one_line

        labelled = "labelled" if self.labels is not None else "unlabelled"
        crs = crs_name(self.crs) if self.crs else None
        extra = f", {len(self.attributes)} attributes" if self.attributes else ""
        return one_line(f"<PointCloud {len(self):,} points, {labelled}{extra}" + (f", {crs}" if crs else "")
                        + (f", from {self.path}" if self.path else "") + ">")

    def __post_init__(self):
        try:
            xyz = np.asarray(self.xyz)
            if xyz.dtype.kind not in "iuf":  # complex, booleans, strings, objects
                raise TypeError
            xyz = xyz.astype(np.float64, copy=False)
        except (TypeError, ValueError):
            raise LidarSigError(f"coordinates must be numbers, an (N, 3) array; got {type(self.xyz).__name__}",
                                path=self.path) from None
        if xyz.ndim != 2 or xyz.shape[1] != 3:
            raise LidarSigError(f"coordinates must have shape (N, 3), got {xyz.shape}", path=self.path)
        if xyz.shape[0] == 0:
            raise LidarSigError(f"the {'file' if self.path else 'cloud'} holds no points; give one with points",
                                path=self.path)
        if not np.isfinite(np.concatenate(bounds(xyz))).all():  # a column's min or max is NaN or infinite if a value is
            bad = ~np.isfinite(xyz).all(axis=1)
            raise LidarSigError(
                f"{_have(int(bad.sum()))} NaN or infinite coordinates (first at index "
                f"{int(np.argmax(bad))}); remove them before running", path=self.path)
        if self.units is None:
            self.units = units_of(self.crs, path=self.path)
        check_magnitude(xyz, self.units.factors, path=self.path)
        self.xyz = xyz
        if self.labels is not None:
            self.labels = _class_codes(self.labels, xyz.shape[0], self.path)
        if self.withheld is not None:
            flags = np.asarray(self.withheld)
            if flags.shape != (xyz.shape[0],) or flags.dtype.kind not in "biu":
                raise LidarSigError(f"withheld must be one flag per point: {flags.shape} {flags.dtype} for "
                                    f"{xyz.shape[0]} points", path=self.path)
            self.withheld = flags.astype(bool) if flags.any() else None

    def __len__(self) -> int:
        return self.xyz.shape[0]

    def subset(self, keep: Any) -> PointCloud:
        """The points ``keep`` (a boolean mask or indices) as a new PointCloud: coordinates,
        labels, withheld flags, CRS, units and path (not the source's record, which describes
        every point of the file)."""
        keep = _checked_rows(keep, len(self), path=self.path)
        return PointCloud(self.xyz[keep], None if self.labels is None else self.labels[keep], path=self.path,
                          crs=self.crs, units=self.units,
                          withheld=None if self.withheld is None else self.withheld[keep])

    def metric_xyz(self) -> np.ndarray:
        """(N, 3) coordinates in metres, centred on the bounding-box centre: what the neighbour
        search and the kernels see (small numbers, so UTM-sized offsets cost no precision)."""
        lo, hi = bounds(self.xyz)
        centre = (lo + hi) / 2.0
        return (self.xyz - centre) * np.asarray(self.units.factors)


def check_magnitude(xyz, factors, *, path=None, start=0):
    """Refuse finite (N, 3) coordinates beyond :data:`MAX_COORDINATE` metres (``factors``:
    metres per unit of x, y and z) with a LidarSigError naming how many, the first and the fix;
    ``start`` is the index in the file of the first row (a chunk of a file)."""
    factors = np.asarray(factors, dtype=np.float64)
    lo, hi = bounds(xyz)
    if np.all(np.maximum(-lo, hi) * factors <= MAX_COORDINATE):
        return  # the usual case, without an (N, 3) temporary
    far = np.abs(xyz) * factors > MAX_COORDINATE
    rows = far.any(axis=1)
    first = int(np.argmax(rows))
    axis = int(np.argmax(far[first]))
    count = int(rows.sum())
    raise LidarSigError(
        f"{_have(count)} a coordinate beyond {MAX_COORDINATE:g} m "
        f"(first at index {start + first}: {'xyz'[axis]} = {xyz[first, axis]:.6g}), too far to measure "
        "neighbours in; remove such points or correct the coordinates (for LAS, the header's scale "
        "and offset)", path=path)


def _have(count):
    return f"{counted(count, 'point')} {'has' if count == 1 else 'have'}"


def _class_codes(labels, n, path):
    """Labels as int64 class codes: one whole number per point, from 0 to 2**31 - 1."""
    from .classes import MAX_CODE

    values = np.asarray(labels)
    if values.shape != (n,):
        raise LidarSigError(f"labels must have one value per point: {values.shape} for {counted(n, 'point')}",
                            path=path)
    if values.dtype.kind not in "iuf" or (values.dtype.kind == "f" and not np.all(np.isfinite(values))):
        raise LidarSigError(f"labels must be class codes (whole numbers), got {values.dtype} values", path=path)
    if values.dtype.kind == "f" and not np.all(values == np.round(values)):
        raise LidarSigError("labels must be class codes (whole numbers), got fractions", path=path)
    if n and (values.min() < 0 or values.max() > MAX_CODE):
        raise LidarSigError(f"labels must be class codes from 0 to {MAX_CODE:,}, got {values.min()} to "
                            f"{values.max()}", path=path)
    return values.astype(np.int64)


def kept_points(labels, withheld, noise_codes):
    """(N,) bool: the points a run uses, or None when it uses every point.

    Left out are the points flagged ``withheld`` (the LAS flag; None when none is) and those
    whose class code (``labels``, None when unlabelled) is one of ``noise_codes``, the class
    table's noise classes (ASPRS 7 low point and 18 high noise). ``noise_codes`` None keeps
    every point (``keep_noise``). They are left out of neighbourhoods, signatures and class
    totals, and get an undefined saliency in per-point outputs, as PDAL and lidR users drop
    them first.
    """
    if noise_codes is None:
        return None
    out = None if withheld is None else ~np.asarray(withheld, dtype=bool)
    if labels is not None and len(noise_codes):
        clean = ~np.isin(labels, np.asarray(noise_codes, dtype=np.int64))
        out = clean if out is None else out & clean
    return None if out is None or out.all() else out


def _checked_rows(keep, n, *, path=None):
    """``keep`` (of :meth:`PointCloud.subset`) checked against ``n`` points: a boolean mask of
    one value per point, or indices from 0 to n - 1 (a negative index would count from the end
    and pick another point than meant); else a LidarSigError naming ``keep``."""
    try:
        keep = np.asarray(keep)
    except (TypeError, ValueError):
        keep = np.asarray(None)
    if keep.dtype == bool and keep.shape == (n,):
        return keep
    if keep.ndim == 1 and (keep.dtype.kind in "iu" or (keep.dtype.kind == "f" and not len(keep))):
        keep = keep.astype(np.int64)
        if len(keep) and (keep.min() < 0 or keep.max() >= n):
            bad = int(keep[(keep < 0) | (keep >= n)][0])
            raise LidarSigError(f"subset: keep holds the index {bad}, outside the cloud's {counted(n, 'point')} "
                                f"(0 to {n - 1:,})", path=path)
        return keep
    raise LidarSigError(f"subset: keep must be a boolean mask of {counted(n, 'value')} or point indices, got "
                        f"{keep.dtype} of shape {keep.shape}", path=path)
