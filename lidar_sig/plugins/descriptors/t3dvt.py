"""T3DVT: tensor voting with ball tensors, then anisotropic diffusion (docs/descriptors.md, "T3DVT")."""
from __future__ import annotations

from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np
from numpy.typing import NDArray

from ...base.errors import LidarSigError
from .._kinds import Descriptor, Kernels

if TYPE_CHECKING:
    from ...numerics.neighbors import NeighborhoodBatch


class T3DVT(Descriptor):
    """Ball-tensor voting for unoriented points with Gaussian decay, then anisotropic diffusion.

    The voting tensor T = sum mu (I - u u^T) / sum mu lives in the normal space (trace 2,
    mu = w_q exp(-d^2 / sigma^2): a Gaussian decay, sigma the scale radius or, for k-nearest
    scales, the distance to the k-th neighbour, times the neighbour's area weight w_q, 1 with
    ``weights="none"``). Diffusion D = sum_j exp(-w_j / delta) e_j e_j^T turns
    it into a tangent-space tensor; the saliency comes from D's eigenvalues, so a plane is
    surface-type and a line line-type.

    Parameters
    ----------
    delta : float
        Diffusion parameter (paper: 0.16).
    diffusion : bool
        False gives the raw voting tensor's saliency (a plane then reads as point-type, the
        "partitioning line" of the paper's signature figure).

    References
    ----------
    Sreevalsan-Nair & Kumari (2017); Sreevalsan-Nair, Jindal & Kumari (2018).
    """

    name = "t3dvt"
    summary = "tensor voting with ball tensors and anisotropic diffusion (T3DVT)"
    kernels: ClassVar[Kernels] = (("lidar_sig.numerics.kernels", ("voting_eigenvalues",)),)

    def __init__(self, delta: float = 0.16, diffusion: bool = True) -> None:
        if not delta > 0:
            raise LidarSigError(f"diffusion delta must be positive, got {delta}")
        self.delta = float(delta)
        self.diffusion = bool(diffusion)

    def params(self) -> dict[str, Any]:
        return {"delta": self.delta, "diffusion": self.diffusion}

    def eigenvalues(self, batch: NeighborhoodBatch) -> NDArray[np.float64]:
        from ...numerics.kernels import voting_eigenvalues  # numba: loaded to compute, not to list plugins

        w: NDArray[np.float64] = voting_eigenvalues(batch.xyz, batch.rows, batch.idx, batch.counts, batch.sigma,
                                                    batch.weights)
        if not self.diffusion:
            return w
        # eig(D) = exp(-w / delta): the order reverses, so the descending ones come from the
        # ascending w.
        return np.exp(-w[..., ::-1] / self.delta)
