"""Optimal-scale: per point, the scale of minimum geometric entropy (docs/method.md, "Strategies")."""
from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from ...method.saliency_map import geometric_entropy
from ...method.scales import PAPER_K
from .._kinds import Strategy


class OptimalScale(Strategy):
    """Per point, the saliency map at the scale of minimum Egeom (first on ties).

    Paper default: k-nearest scales k = 10, 20, ..., 100. The chosen scale index is returned.
    """

    name = "optimal"
    summary = "saliency at the scale of minimum entropy (default k = 10, 20, ..., 100)"
    default_scales = PAPER_K
    chooses_scale = True

    def combine(self, per_scale: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.int64] | None]:
        entropy = geometric_entropy(per_scale)
        undefined = np.isnan(entropy).all(axis=1)
        chosen = np.argmin(np.where(np.isnan(entropy), np.inf, entropy), axis=1)
        out = np.take_along_axis(per_scale, chosen[:, None, None], axis=1)[:, 0]
        chosen = chosen.astype(np.int64)
        chosen[undefined] = -1
        out[undefined] = np.nan
        return out, chosen
