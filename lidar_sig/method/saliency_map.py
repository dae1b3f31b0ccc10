"""Saliency map (docs/method.md, "Saliency map"): eigenvalues -> (Cl, Cs, Cp), geometric uncertainty Egeom, class."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..numerics.bounds import nan_rows

LN3 = float(np.log(3.0))
#: Codes of the deterministic geometric class, as written to LAS (GeomClass).
GEOM_CLASSES = {0: "undefined", 1: "line", 2: "surface", 3: "point"}


def saliency_from_eigenvalues(ev: ArrayLike) -> NDArray[np.float64]:
    """(Cl, Cs, Cp) from eigenvalues sorted l0 >= l1 >= l2 >= 0 on the last axis (docs/method.md, "Saliency map").

    Cl = (l0 - l1)/S, Cs = 2 (l1 - l2)/S, Cp = 3 l2/S with S = l0 + l1 + l2; they sum to 1.
    NaN where S = 0 or the eigenvalues are NaN (undefined saliency).
    """
    from ..numerics.kernels import saliency_rows  # numba, loaded when saliency is first computed

    ev = np.ascontiguousarray(ev, dtype=np.float64)
    out = np.empty_like(ev)
    saliency_rows(ev.reshape(-1, 3), out.reshape(-1, 3))
    return out


def geometric_entropy(sal: ArrayLike) -> NDArray[np.float64]:
    """Egeom = -(Cl ln Cl + Cs ln Cs + Cp ln Cp), 0 ln 0 = 0; in [0, ln 3] nats (docs/method.md, "Saliency map").

    NaN where the saliency is undefined.
    """
    from ..numerics.kernels import entropy_rows

    sal = np.ascontiguousarray(sal, dtype=np.float64)
    out = np.empty(sal.shape[:-1])
    entropy_rows(sal.reshape(-1, 3), out.reshape(-1), LN3)
    return out


def geometric_class(sal: ArrayLike) -> NDArray[np.uint8]:
    """Deterministic class: 1 line, 2 surface, 3 point (argmax, first on ties); 0 if undefined."""
    sal = np.asarray(sal)
    # column by column: numpy's any over a last axis of 3 takes four times as long
    undefined = nan_rows(sal.reshape(-1, sal.shape[-1])).reshape(sal.shape[:-1])
    cls = np.argmax(np.where(undefined[..., None], 0.0, sal), axis=-1).astype(np.uint8) + 1
    cls[undefined] = 0
    return cls


@dataclass(repr=False)
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

    def __repr__(self):
        n = len(self.values)
        undefined = int(nan_rows(self.values).sum()) if n else 0
        mean = np.nanmean(self.values, axis=0) if n > undefined else np.full(3, np.nan)
        return (f"<Saliency {n:,} points, {undefined:,} undefined; mean Cl {mean[0]:.3f}, Cs {mean[1]:.3f}, "
                f"Cp {mean[2]:.3f}" + (", with the optimal scale" if self.optimal_scale is not None else "") + ">")

    @classmethod
    def from_values(cls, values: np.ndarray, optimal_scale: np.ndarray | None = None) -> Saliency:
        values = np.asarray(values, dtype=np.float64)
        return cls(values, geometric_entropy(values), geometric_class(values), optimal_scale)

    @classmethod
    def of_kept(cls, values, optimal_scale, kept):
        """The Saliency of every point of a cloud whose points ``kept`` ((N,) bool) alone were
        computed, with ``values`` (M, 3) and ``optimal_scale`` (M,) or None: the others are
        undefined (NaN, class 0, scale -1)."""
        full = np.full((len(kept), 3), np.nan)
        full[kept] = values
        chosen = None
        if optimal_scale is not None:
            chosen = np.full(len(kept), -1, dtype=np.int64)
            chosen[kept] = optimal_scale
        return cls.from_values(full, chosen)

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
