"""Multiscale: the average of the per-scale saliency maps (SPEC 4)."""
import warnings

import numpy as np

from ...scales import radii
from ..base import Strategy


class Multiscale(Strategy):
    """Average of (Cl, Cs, Cp) over the scales where the saliency is defined.

    Paper default: spherical radii 0.009, 0.010, 0.011 in normalized units.
    """

    name = "multiscale"
    summary = "average saliency over scales (paper: normalized radii 0.009, 0.010, 0.011)"
    default_scales = radii(0.009, 0.010, 0.011, units="normalized")

    def combine(self, per_scale):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)  # all-NaN rows stay NaN
            return np.nanmean(per_scale, axis=1), None
