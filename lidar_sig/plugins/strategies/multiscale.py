"""Multiscale: the average of the per-scale saliency maps (SPEC 4)."""
import warnings

import numpy as np

from ...scales import knn
from ..base import Strategy


class Multiscale(Strategy):
    """Average of (Cl, Cs, Cp) over the scales where the saliency is defined.

    Default scales: k = 20, 30, 40 nearest neighbours, chosen by the ordering benchmark
    (docs/comparison.md); the paper's are spherical radii 0.009, 0.010, 0.011 in normalized
    units, ``radii(0.009, 0.010, 0.011, units="normalized")``.
    """

    name = "multiscale"
    summary = "average saliency over scales (default k = 20, 30, 40)"
    default_scales = knn(20, 30, 40)

    def combine(self, per_scale):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)  # all-NaN rows stay NaN
            return np.nanmean(per_scale, axis=1), None
