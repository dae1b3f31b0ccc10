"""C3DCM: the covariance tensor of a neighbourhood (docs/method.md, "C3DCM")."""
from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from .._kinds import Descriptor

if TYPE_CHECKING:
    from ...numerics.neighbors import NeighborhoodBatch


class C3DCM(Descriptor):
    """3D covariance matrix T = (1/n) sum (q - qbar)(q - qbar)^T, x_i included.

    References
    ----------
    Sreevalsan-Nair & Kumari (2017); Sreevalsan-Nair & Mohapatra, section on descriptors.
    """

    name = "c3dcm"
    summary = "covariance tensor of the neighbourhood (C3DCM)"
    kernels = (("lidar_sig.numerics.kernels", ("covariance_eigenvalues",)),)

    def eigenvalues(self, batch: NeighborhoodBatch) -> NDArray[np.float64]:
        from ...numerics.kernels import covariance_eigenvalues  # numba: loaded to compute, not to list plugins

        eigenvalues: NDArray[np.float64] = covariance_eigenvalues(batch.xyz, batch.rows, batch.idx, batch.counts,
                                                                  batch.weights)
        return eigenvalues
