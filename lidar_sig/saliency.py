"""Saliency map (SPEC 1): eigenvalues -> (Cl, Cs, Cp), geometric uncertainty Egeom, class."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

LN3 = float(np.log(3.0))
#: Codes of the deterministic geometric class, as written to LAS (GeomClass).
GEOM_CLASSES = {0: "undefined", 1: "line", 2: "surface", 3: "point"}


def saliency_from_eigenvalues(ev):
    """(Cl, Cs, Cp) from eigenvalues sorted l0 >= l1 >= l2 >= 0 on the last axis (SPEC 1).

    Cl = (l0 - l1)/S, Cs = 2 (l1 - l2)/S, Cp = 3 l2/S with S = l0 + l1 + l2; they sum to 1.
    NaN where S = 0 or the eigenvalues are NaN (undefined saliency).
    """
    ev = np.asarray(ev, dtype=np.float64)
    l0, l1, l2 = ev[..., 0], ev[..., 1], ev[..., 2]
    total = l0 + l1 + l2
    with np.errstate(invalid="ignore", divide="ignore"):
        inv = np.where(total > 0, 1.0 / total, np.nan)
    return np.stack([(l0 - l1) * inv, 2.0 * (l1 - l2) * inv, 3.0 * l2 * inv], axis=-1)


def geometric_entropy(sal):
    """Egeom = -(Cl ln Cl + Cs ln Cs + Cp ln Cp), 0 ln 0 = 0; in [0, ln 3] nats (SPEC 1)."""
    sal = np.asarray(sal, dtype=np.float64)
    with np.errstate(invalid="ignore", divide="ignore"):
        terms = np.where(sal > 0, sal * np.log(sal), 0.0)
    out = -terms.sum(axis=-1)
    out[np.isnan(sal).any(axis=-1)] = np.nan
    return np.clip(out, 0.0, LN3)


def geometric_class(sal):
    """Deterministic class: 1 line, 2 surface, 3 point (argmax, first on ties); 0 if undefined."""
    sal = np.asarray(sal)
    undefined = np.isnan(sal).any(axis=-1)
    cls = np.argmax(np.where(undefined[..., None], 0.0, sal), axis=-1).astype(np.uint8) + 1
    cls[undefined] = 0
    return cls


@dataclass
class Saliency:
    """Per-point saliency of a cloud.

    Attributes
    ----------
    values : (N, 3) float64
        (Cl, Cs, Cp) per point, summing to 1; NaN rows where undefined at every scale.
    egeom : (N,) float64
        Geometric uncertainty in nats.
    geom_class : (N,) uint8
        1 line, 2 surface, 3 point, 0 undefined.
    optimal_scale : (N,) int64 or None
        Optimal-scale only: index of the chosen scale in the run's ascending scales, -1 if
        undefined.
    """

    values: np.ndarray
    egeom: np.ndarray
    geom_class: np.ndarray
    optimal_scale: np.ndarray | None = None

    @classmethod
    def from_values(cls, values, optimal_scale=None):
        values = np.asarray(values, dtype=np.float64)
        return cls(values, geometric_entropy(values), geometric_class(values), optimal_scale)

    @property
    def cl(self):
        return self.values[:, 0]

    @property
    def cs(self):
        return self.values[:, 1]

    @property
    def cp(self):
        return self.values[:, 2]

    @property
    def defined(self):
        """Boolean mask of points with a defined saliency."""
        return self.geom_class != 0
