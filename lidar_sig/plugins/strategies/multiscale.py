"""Multiscale: the average of the per-scale saliency maps (docs/method.md, "Strategies")."""
from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from ...method.scales import knn
from .._kinds import Strategy


class Multiscale(Strategy):
    """Average of (Cl, Cs, Cp) over the scales where the saliency is defined.

    Default scales: k = 20, 30, 40 nearest neighbours, chosen by the ordering benchmark
    (docs/comparison.md); the paper's are spherical radii 0.009, 0.010, 0.011 in normalized
    units, ``radii(0.009, 0.010, 0.011, units="normalized")``.
    """

    name = "multiscale"
    summary = "average saliency over scales (default k = 20, 30, 40)"
    default_scales = knn(20, 30, 40)
    kernels = (("lidar_sig.numerics.kernels", ("mean_over_scales",)),)

    def combine(self, per_scale: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.int64] | None]:
        from ...numerics.kernels import mean_over_scales  # numba loads with the first kernel a run calls

        # numpy.nanmean's result (all-NaN rows stay NaN) in one pass over the (B, S, 3) values
        per_scale = np.ascontiguousarray(per_scale, dtype=np.float64)
        out = np.empty((per_scale.shape[0], per_scale.shape[2]))
        mean_over_scales(per_scale, out)
        return out, None
