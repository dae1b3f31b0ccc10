"""Scales of a run: k-nearest counts or spherical radii, metric or normalized (docs/method.md,
"Neighbourhoods and scales").

Metric radii are metres (a survey in feet is converted, see :mod:`lidar_sig.method.crs`). Normalized
radii are the paper's: r_n times half the longest side of the cloud's axis-aligned bounding box.
They make a result independent of the unit but not of rotation or of how the tile was cut: the
box turns and changes with the cloud.
"""
from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..numerics.bounds import bounds
from ..numerics.neighbors import ScaleKind
from ..base.errors import LidarSigError

UNITS = ("metric", "normalized")
#: Largest radius accepted: 100 km (metric), ten half-sides (normalized: far beyond the cloud).
MAX_RADIUS = {"metric": 1e5, "normalized": 10.0}
#: Largest k accepted (a neighbourhood of k points is held per query point).
MAX_K = 100_000


@dataclass(frozen=True)
class Scales:
    """The scales of one run, sorted ascending.

    kind is a :class:`ScaleKind`, given as its text: ``"radius"`` (spherical neighbourhoods,
    ``values`` in ``units``: ``"metric"``, metres, or ``"normalized"``) or ``"knn"`` (``values``
    are neighbour counts k, x_i included, extended to every point tied with the k-th).
    """

    kind: ScaleKind
    values: tuple[float, ...]
    units: str | None = None

    def __post_init__(self) -> None:
        try:
            object.__setattr__(self, "kind", ScaleKind(self.kind))
        except ValueError:
            raise LidarSigError(f"scale kind must be one of {', '.join(map(repr, ScaleKind))}, "
                                f"got {self.kind!r}") from None
        if not self.values:
            raise LidarSigError("give at least one scale")
        if not self.kind.by_count:
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
    def by_count(self) -> bool:
        """True for k-nearest scales (whole numbers of points), False for radii."""
        return self.kind.by_count

    @property
    def normalized(self) -> bool:
        """True for radii given as shares of half the cloud's longest side (resolved per cloud)."""
        return self.units == "normalized"

    def fewest_points(self, min_neighbors: int) -> int:
        """Fewest distinct locations a cloud needs for these scales: the largest k, or
        ``min_neighbors`` (the fewest a saliency needs) for radii."""
        return int(max(self.values)) if self.by_count else int(min_neighbors)

    @property
    def kernels(self) -> tuple[tuple[str, tuple[str, ...]], ...]:
        """Compiled kernels the neighbour search calls for these scales besides those of every
        run (:data:`lidar_sig.base.compile.COMMON`), as (module, function names): radius scales are
        counted within each sphere; k-nearest scales are counted by the search itself (the few
        rows it leaves to a scan are counted by a kernel loaded when first needed)."""
        return () if self.by_count else (("lidar_sig.numerics._voxels", ("count_within",)),)

    def resolve(self, xyz: np.ndarray) -> np.ndarray:
        """Scales for coordinates ``xyz`` in metres (:meth:`PointCloud.metric_xyz`): radii in
        metres as float64, k as int64.

        A normalized radius r_n becomes r_n times half the longest bounding-box side
        (paper, footnote on scales; docs/method.md, "Neighbourhoods and scales").
        """
        if self.by_count:
            return np.asarray(self.values, dtype=np.int64)
        factor = 1.0
        if self.normalized:
            lo, hi = bounds(xyz)
            factor = float((hi - lo).max()) / 2.0
        return np.asarray(self.values, dtype=np.float64) * factor

    def describe(self) -> str:
        """Short human-readable text, e.g. ``radii 0.009, 0.01, 0.011 (normalized)``."""
        if self.by_count:
            return "k " + ", ".join(str(v) for v in self.values)
        unit = " (normalized)" if self.normalized else " m"
        return "radii " + ", ".join(f"{v:g}" for v in self.values) + unit


def radii(*values: float, units: str = "metric") -> Scales:
    """Spherical scales, in metres or ``units="normalized"`` (the paper's Multiscale setting is
    ``radii(0.009, 0.010, 0.011, units="normalized")``)."""
    return Scales(ScaleKind.RADIUS, tuple(values), units)


def knn(*values: int) -> Scales:
    """k-nearest scales (x_i included); the package's Multiscale default is ``knn(20, 30, 40)``,
    the paper's Optimal-scale setting ``knn(*range(10, 101, 10))``."""
    return Scales(ScaleKind.KNN, tuple(values))


def recorded_kind(meta: Mapping[str, Any]) -> ScaleKind | None:
    """The kind of scales a run's metadata records (``scale_kind``), None when it records none
    or one this version does not know."""
    try:
        return ScaleKind(meta["scale_kind"])
    except (KeyError, ValueError):
        return None


def recorded_scales(meta: Mapping[str, Any]) -> Scales | None:
    """The scales a run's metadata or method records (``scale_kind``, ``scale_values``,
    ``scale_units``: :meth:`lidar_sig.Pipeline.method`), None when it records none; a
    LidarSigError when the recorded values are not scales."""
    kind = recorded_kind(meta)
    if kind is None or "scale_values" not in meta:
        return None
    units = None if kind.by_count else meta.get("scale_units") or "metric"
    return Scales(kind, tuple(meta["scale_values"]), units)


#: The paper's scales: Multiscale over normalized radii 0.009, 0.010, 0.011, Optimal-scale over
#: k = 10, 20, ..., 100 (with ``weights="none"`` and the ``points`` rendering, its setting).
PAPER_RADII = radii(0.009, 0.010, 0.011, units="normalized")
PAPER_K = knn(*range(10, 101, 10))
