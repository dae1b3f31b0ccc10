"""The height component of a cell's comparison, one more augmentation of its signature
(docs/changes.md, "The height component"): the distribution of the cell's heights above its own
lowest points, compared between the epochs as an earth mover's distance in metres (delta_H).

The signature sees the shape of the neighbourhoods (Cl, Cs, Cp) and the classes, not how high
things are: earth moved by a few metres keeps flat ground flat and ground ground. Heights taken
above each cell's own lowest points need no registration (a vertical offset between the epochs
cancels) and do not change with a rotation about the vertical or a translation; they are in
metres whatever the CRS unit. Pure array functions.
"""
from __future__ import annotations

import numpy as np

#: Key and name of the height component, beside :data:`lidar_sig.metrics.METRIC_KEYS`.
HEIGHT = "height"
HEIGHT_NAME = "delta_H"
#: The cell's lowest points: its heights are taken above this quantile of its z (2%, so that a
#: few low outliers do not set it).
LOWEST = 0.02
#: Quantile levels at which two cells' height distributions are compared (the earth mover's
#: distance of two 1-D distributions is the mean distance between their quantile functions).
LEVELS = (np.arange(100) + 0.5) / 100


#: Where :func:`height_profile` reads the sorted heights: the lowest points, then every level.
_AT = np.concatenate([[LOWEST], LEVELS])


def height_profile(z):
    """The quantile function of heights ``z`` (metres) above their :data:`LOWEST` quantile, at
    :data:`LEVELS`: numpy's default (linear) quantiles, read off one sort of ``z`` (numpy's
    quantile partitions the array once per level, and the change map asks for the profile
    fourteen times per compared cell: docs/performance.md, "The change map")."""
    s = np.sort(np.asarray(z, dtype=np.float64))
    q = np.interp(_AT * (len(s) - 1), np.arange(len(s)), s)
    return q[1:] - q[0]


def height_distance(z_a, z_b):
    """delta_H: the earth mover's distance (metres) between the heights of two sets of points
    above their own lowest points (:func:`height_profile`); 0 for identical sets."""
    return float(np.mean(np.abs(height_profile(z_a) - height_profile(z_b))))
