"""Selecting and joining structured record arrays (the work folder's staged and coded points)
as whole records: numpy copies a structured array's elements field by field when it indexes,
masks or joins them, three to ten times slower than the same bytes taken as one opaque item
each (docs/performance.md, "The change map at survey scale"). Their stable order by a key is
:func:`lidar_sig.numerics.sorting.stable_order`."""
from __future__ import annotations

import numpy as np


def _opaque(rec):
    """``rec`` (contiguous) seen as one void item per record."""
    rec = np.ascontiguousarray(rec)
    return rec.view(np.dtype((np.void, rec.dtype.itemsize)))


def pick(rec, which):
    """``rec[which]`` (a mask or indices), the same values, copied record by record."""
    return _opaque(rec)[which].view(rec.dtype)


def join(parts, dtype):
    """The record arrays ``parts`` (of ``dtype``) end to end: ``np.concatenate(parts)``."""
    if not parts:
        return np.empty(0, dtype)
    return np.concatenate([_opaque(p) for p in parts]).view(dtype)

