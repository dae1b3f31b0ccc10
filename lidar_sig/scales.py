"""Scales of a run: spherical radii (metric or normalized) or k-nearest counts (SPEC 2)."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .errors import LidarSigError

UNITS = ("normalized", "metric")


@dataclass(frozen=True)
class Scales:
    """The scales of one run, sorted ascending.

    kind is ``"radius"`` (spherical neighbourhoods, ``values`` in ``units``) or ``"knn"``
    (``values`` are neighbour counts k, x_i included).
    """

    kind: str
    values: tuple
    units: str | None = None

    def __post_init__(self):
        if self.kind not in ("radius", "knn"):
            raise LidarSigError(f"scale kind must be 'radius' or 'knn', got {self.kind!r}")
        if not self.values:
            raise LidarSigError("give at least one scale")
        if self.kind == "radius":
            if self.units not in UNITS:
                raise LidarSigError(f"radius units must be one of {UNITS}, got {self.units!r}")
            vals = tuple(sorted(float(v) for v in self.values))
            if not all(np.isfinite(v) and v > 0 for v in vals):
                raise LidarSigError(f"radii must be positive numbers, got {self.values}")
        else:
            vals = tuple(sorted(int(v) for v in self.values))
            if any(v < 2 or v != float(w) for v, w in zip(vals, sorted(self.values))):
                raise LidarSigError(f"k must be whole numbers >= 2, got {self.values}")
        if len(set(vals)) != len(vals):
            raise LidarSigError(f"scales must be distinct, got {self.values}")
        object.__setattr__(self, "values", vals)

    def __len__(self):
        return len(self.values)

    def resolve(self, cloud):
        """Scales in the cloud's coordinate units: radii as float64, k as int64.

        A normalized radius r_n becomes r_n times half the longest bounding-box side
        (paper, footnote on scales; SPEC 2).
        """
        if self.kind == "knn":
            return np.asarray(self.values, dtype=np.int64)
        factor = cloud.half_longest_side if self.units == "normalized" else 1.0
        return np.asarray(self.values, dtype=np.float64) * factor

    def describe(self):
        """Short human-readable text, e.g. ``radii 0.009, 0.01, 0.011 (normalized)``."""
        if self.kind == "knn":
            return "k " + ", ".join(str(v) for v in self.values)
        return "radii " + ", ".join(f"{v:g}" for v in self.values) + f" ({self.units})"


def radii(*values, units="normalized"):
    """Spherical scales; the paper's Multiscale default is ``radii(0.009, 0.010, 0.011)``."""
    return Scales("radius", tuple(values), units)


def knn(*values):
    """k-nearest scales; the paper's Optimal-scale default is ``knn(*range(10, 101, 10))``."""
    return Scales("knn", tuple(values))
