"""Per-column minima and maxima of point arrays ((N, D) coordinates or voxel indices), and their
rows holding a NaN.

numpy reduces a C-ordered (N, 3) array along axis 0 or 1 far more slowly than it reduces each of
its columns in turn (docs/performance.md has the figures); the values are the same. Every
bounding box of a whole cloud, and every test of a whole cloud's rows for NaN, is taken here.
"""
from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray


def column_min(a):
    """(D,) minimum of each column of ``a`` (N, D), N >= 1."""
    a = np.asarray(a)
    return np.array([a[:, j].min() for j in range(a.shape[1])], dtype=a.dtype)


def column_max(a):
    """(D,) maximum of each column of ``a`` (N, D), N >= 1."""
    a = np.asarray(a)
    return np.array([a[:, j].max() for j in range(a.shape[1])], dtype=a.dtype)


def bounds(a: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """(lo, hi): the per-column minima and maxima of ``a`` (N, D), N >= 1."""
    return column_min(a), column_max(a)


def nan_rows(a: ArrayLike) -> NDArray[np.bool_]:
    """(N,) bool: the rows of ``a`` (N, D) holding a NaN (``np.isnan(a).any(axis=1)``)."""
    a = np.asarray(a)
    out = np.zeros(a.shape[0], dtype=bool)
    for j in range(a.shape[1]):
        out |= np.isnan(a[:, j])
    return out
