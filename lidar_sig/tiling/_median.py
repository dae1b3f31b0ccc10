"""The exact median of values kept in several sorted files, without holding them: what
``numpy.median`` gives on their concatenation, from binary searches in the mapped files (the
set's area-weight cap, :func:`lidar_sig.numerics.neighbors.area_cap`, over every distinct location
of a set run in tiles up to CAP_POINTS points, or above when the cap's sample holds none)."""
from __future__ import annotations

import numpy as np


def sorted_median(paths):
    """``numpy.median`` of the concatenated contents of the .npy files ``paths``, each a 1-D
    array of finite non-negative floats in ascending order; NaN when they hold none."""
    arrays = [np.load(p, mmap_mode="r") for p in paths]
    arrays = [a for a in arrays if len(a)]
    n = sum(len(a) for a in arrays)
    if not n:
        return float("nan")
    low = _kth(arrays, (n - 1) // 2)
    high = low if n % 2 else _kth(arrays, n // 2)
    return float(np.mean([low, high]))  # as numpy.median: the mean of the two middle values


def _kth(arrays, k):
    """The ``k``-th smallest (0-based) of the values of sorted ``arrays``: bisection on the
    values' bits (for non-negative floats their order as integers is their order as numbers)."""
    lo = min(np.float64(a[0]) for a in arrays).view(np.int64)
    hi = max(np.float64(a[-1]) for a in arrays).view(np.int64)
    while lo < hi:  # the smallest value v with more than k values <= v
        mid = lo + (hi - lo) // 2
        v = np.int64(mid).view(np.float64)
        if sum(int(np.searchsorted(a, v, side="right")) for a in arrays) > k:
            hi = mid
        else:
            lo = mid + 1
    return np.int64(lo).view(np.float64)
