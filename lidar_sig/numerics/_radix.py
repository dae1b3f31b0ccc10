"""The radix sort (numba) behind :func:`lidar_sig.numerics.sorting.stable_order`."""
from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True)
def radix_order(keys, bits, digit):
    """Stable order of ``keys`` (non-negative, below 2**bits) by least-significant-digit radix
    passes of at most ``digit`` bits; the keys travel with the order, so that each pass reads
    them in sequence."""
    n = len(keys)
    order = np.arange(n)
    spare = np.empty(n, np.int64)
    k = keys.copy()
    k_spare = np.empty_like(k)
    passes = max(1, (bits + digit - 1) // digit)
    width = (bits + passes - 1) // passes  # equal passes: fewer counts than digit bits each
    mask = (1 << width) - 1
    shift = 0
    for _ in range(passes):
        counts = np.zeros(mask + 2, np.int64)
        for i in range(n):
            counts[((k[i] >> shift) & mask) + 1] += 1
        for b in range(mask + 1):
            counts[b + 1] += counts[b]
        for i in range(n):
            d = (k[i] >> shift) & mask
            c = counts[d]
            spare[c] = order[i]
            k_spare[c] = k[i]
            counts[d] = c + 1
        order, spare = spare, order
        k, k_spare = k_spare, k
        shift += width
    return order
