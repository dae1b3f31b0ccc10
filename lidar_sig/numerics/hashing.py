"""64-bit hashes of integer places, and the share of them below a threshold: how a sample is
picked as a function of where points are (a change map's points, docs/changes.md; the
area-weight cap's windows, docs/method.md "Neighbour weights"), never of their order."""
from __future__ import annotations

import numpy as np

#: 2^64 / the golden ratio: offsets one coordinate's hash from another's.
GOLDEN = np.uint64(0x9E3779B97F4A7C15)


def mix64(x):
    """splitmix64's finaliser: every bit of ``x`` (uint64) moves about half of the output's."""
    with np.errstate(over="ignore"):
        x = (x ^ (x >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
        x = (x ^ (x >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
        return x ^ (x >> np.uint64(31))


def hash2(i, j):
    """(N,) uint64 hash of the integer pairs ``i``, ``j`` (int64 or uint64): each mixed, the
    second offset first, so that (i, j) and (j, i) differ."""
    with np.errstate(over="ignore"):
        return mix64(np.asarray(i).view(np.uint64)) ^ mix64(np.asarray(j).view(np.uint64) + GOLDEN)


def below_share(keys, share):
    """(N,) bool: the uint64 ``keys`` in the lowest ``share`` (at most 1) of their range."""
    return keys < np.uint64(min(int(share * 2.0 ** 64), 2 ** 64 - 1))
