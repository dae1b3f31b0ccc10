"""Scales of a run: k-nearest counts or spherical radii, metric or normalized (docs/method.md,
"Neighbourhoods and scales").

Metric radii are metres (a survey in feet is converted, see :mod:`lidar_sig.method.crs`). Normalized
radii are the paper's: r_n times half the longest side of the cloud's axis-aligned bounding box.
They make a result independent of the unit but not of rotation or of how the tile was cut: the
box turns and changes with the cloud.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..numerics.bounds import bounds
from ..base.errors import LidarSigError

UNITS = ("metric", "normalized")
#: Largest radius accepted: 100 km (metric), ten half-sides (normalized: far beyond the cloud).
MAX_RADIUS = {"metric": 1e5, "normalized": 10.0}
#: Largest k accepted (a neighbourhood of k points is held per query point).
MAX_K = 100_000


@dataclass(frozen=True)
class Scales:
    """The scales of one run, sorted ascending.

    kind is ``"radius"`` (spherical neighbourhoods, ``values`` in ``units``: ``"metric"``,
    metres, or ``"normalized"``) or ``"knn"`` (``values`` are neighbour counts k, x_i included,
    extended to every point tied with the k-th).
    """

    kind: str
    values: tuple[float, ...]
    units: str | None = None

    def __post_init__(self):
        if self.kind not in ("radius", "knn"):
            raise LidarSigError(f"scale kind must be 'radius' or 'knn', got {self.kind!r}")
        if not self.values:
            raise LidarSigError("give at least one scale")
        if self.kind == "radius":
            if self.units not in UNITS:
                raise LidarSigError(f"radius units must be one of {UNITS}, got {self.units!r}")
            try:
                vals = tuple(sorted(float(v) for v in self.values))
            except (TypeError, ValueError):
                raise LidarSigError(f"radii must be numbers, got {self.values}") from None
            limit = MAX_RADIUS[self.units]
            if not all(np.isfinite(v) and 0 < v <= limit for v in vals):
                raise LidarSigError(f"{self.units} radii must be positive and at most {limit:g}, got "
                                    f"{self.values}")
        else:
            try:
                vals = tuple(sorted(float(v) for v in self.values))
            except (TypeError, ValueError):
                raise LidarSigError(f"k must be whole numbers, got {self.values}") from None
            if not all(np.isfinite(v) and v == int(v) and 2 <= v <= MAX_K for v in vals):
                raise LidarSigError(f"k must be whole numbers from 2 to {MAX_K:,}, got {self.values}")
            vals = tuple(int(v) for v in vals)
        if len(set(vals)) != len(vals):
            raise LidarSigError(f"scales must be distinct, got {self.values}")
        object.__setattr__(self, "values", vals)

    def __len__(self) -> int:
        return len(self.values)

    @property
    def kernels(self):
        """Compiled kernels the neighbour search calls for these scales besides those of every
        run (:data:`lidar_sig.base.compile.COMMON`), as (module, function names): radius scales are
        counted within each sphere; k-nearest scales are counted by the search itself (the few
        rows it leaves to a scan are counted by a kernel loaded when first needed)."""
        return (("lidar_sig.numerics._voxels", ("count_within",)),) if self.kind == "radius" else ()

    def resolve(self, xyz: np.ndarray) -> np.ndarray:
        """Scales for coordinates ``xyz`` in metres (:meth:`PointCloud.metric_xyz`): radii in
        metres as float64, k as int64.

        A normalized radius r_n becomes r_n times half the longest bounding-box side
        (paper, footnote on scales; docs/method.md, "Neighbourhoods and scales").
        """
        if self.kind == "knn":
            return np.asarray(self.values, dtype=np.int64)
        factor = 1.0
        if self.units == "normalized":
            lo, hi = bounds(xyz)
            factor = float((hi - lo).max()) / 2.0
        return np.asarray(self.values, dtype=np.float64) * factor

    def describe(self) -> str:
        """Short human-readable text, e.g. ``radii 0.009, 0.01, 0.011 (normalized)``."""
        if self.kind == "knn":
            return "k " + ", ".join(str(v) for v in self.values)
        unit = " m" if self.units == "metric" else " (normalized)"
        return "radii " + ", ".join(f"{v:g}" for v in self.values) + unit


def radii(*values: float, units: str = "metric") -> Scales:
    """Spherical scales, in metres or ``units="normalized"`` (the paper's Multiscale setting is
    ``radii(0.009, 0.010, 0.011, units="normalized")``)."""
    return Scales("radius", tuple(values), units)


def knn(*values: int) -> Scales:
    """k-nearest scales (x_i included); the package's Multiscale default is ``knn(20, 30, 40)``,
    the paper's Optimal-scale setting ``knn(*range(10, 101, 10))``."""
    return Scales("knn", tuple(values))


#: The paper's scales: Multiscale over normalized radii 0.009, 0.010, 0.011, Optimal-scale over
#: k = 10, 20, ..., 100 (with ``weights="none"`` and the ``points`` rendering, its setting).
PAPER_RADII = radii(0.009, 0.010, 0.011, units="normalized")
PAPER_K = knn(*range(10, 101, 10))
