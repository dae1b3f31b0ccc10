"""The stable order of non-negative integer keys, by radix (docs/performance.md, "Sorting and
loading"): numpy sorts 16-bit keys by radix but wider ones by timsort, two to eight times
slower than a radix pass over only the bits the keys use. The order is the one
``np.argsort(keys, kind="stable")`` gives, to the element: records by cell or by work unit,
points by voxel or by the hash of their coordinates."""
from __future__ import annotations

import numpy as np

#: Bits a radix pass takes at most: its counts (8,192 of them) stay in the fastest cache.
DIGIT = 13
#: Fewer keys than this are sorted by numpy: a radix pass's counts would cost more than the keys.
_SMALL = 4096


def stable_order(keys):
    """``np.argsort(keys, kind="stable")`` of non-negative integer ``keys`` (unsigned 64-bit
    keys may use every bit); the passes cover the bits of the largest key."""
    keys = np.asarray(keys)
    n_keys = int(keys.max(initial=0)) + 1
    if n_keys <= np.iinfo(np.int16).max:
        return np.argsort(keys.astype(np.int16), kind="stable")  # numpy's own radix sort
    if len(keys) < _SMALL:
        return np.argsort(keys, kind="stable")
    if keys.dtype == np.uint64:  # the same bits as int64: the top pass orders them unsigned
        keys = keys.view(np.int64)
    from ._radix import radix_order  # numba: loaded when a sort is this large, not on import

    return radix_order(np.ascontiguousarray(keys, dtype=np.int64), (int(n_keys) - 1).bit_length(), DIGIT)
