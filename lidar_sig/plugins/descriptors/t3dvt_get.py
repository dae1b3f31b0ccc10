"""T3DVT-GET: tensor voting modified by the 2D gradient energy tensor of the height field."""
from __future__ import annotations

import warnings
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from ...numerics.bounds import nan_rows
from .t3dvt import T3DVT

if TYPE_CHECKING:
    from ...numerics.neighbors import NeighborhoodBatch, ScaleKind

#: Default threshold on the dimensionless GET magnitude m0 * r^2; see docs/descriptors.md for
#: the measurements on the IGN tiles that chose it.
GET_THRESHOLD = 1.0


class T3DVTGET(T3DVT):
    """T3DVT whose saliency becomes a corner (cl_GET, 0, cp_GET) where GET says so (docs/descriptors.md, "T3DVT-GET").

    GET is computed on cylindrical neighbourhoods (horizontal distance <= r, or the k nearest in
    plan view) at the run's scales; its line/corner saliency cl_GET is combined over the scales
    like the voting saliency: under Multiscale the mean over the scales where GET is defined,
    under Optimal-scale its value at the point's chosen scale. Wherever cp_GET > cl_GET the
    point's saliency is replaced by (cl_GET, 0, cp_GET), if the voting saliency is defined (a
    point without enough neighbours in its spheres stays undefined, whatever GET says). GET
    assumes z is up: results are invariant to rotations about z only.

    Parameters
    ----------
    get_threshold : float
        GET counts at a scale only where its largest eigenvalue times the squared scale radius
        (dimensionless) reaches this value; 0 keeps every positive GET, so that flat or evenly
        sloped ground, where GET is numerically zero, turns into noise corners.
    delta, diffusion
        As for T3DVT.
    """

    name = "t3dvt-get"
    summary = "tensor voting modified by the gradient energy tensor of the height field (T3DVT-GET)"
    kernels = (("lidar_sig.numerics.kernels", ("voting_eigenvalues",)),
               ("lidar_sig.plugins.descriptors.gradient_energy",
                ("first_pass", "second_pass", "third_pass", "_pack_rows")))

    def __init__(self, delta: float = 0.16, diffusion: bool = True, get_threshold: float = GET_THRESHOLD) -> None:
        super().__init__(delta=delta, diffusion=diffusion)
        self.get_threshold = float(get_threshold)
        self.cl_get: NDArray[np.float64] | None = None

    def params(self) -> dict[str, Any]:
        return {**super().params(), "get_threshold": self.get_threshold}

    def prepare(self, xyz: NDArray[np.float64], kind: ScaleKind, scales: NDArray[Any], *, max_neighbors: int,
                min_neighbors: int, progress: bool | None = None) -> None:
        """(N, S) cl_GET per point (input order) and scale, for the whole cloud."""
        self.cl_get = cl_get_of_cloud(xyz, kind, scales, max_neighbors=max_neighbors,
                                      min_neighbors=min_neighbors, threshold=self.get_threshold,
                                      progress=progress)

    def refine(self, batch: NeighborhoodBatch, saliency: NDArray[np.float64],
               pick: NDArray[np.int64] | None = None) -> NDArray[np.float64]:
        """Corners where cl_GET, at the chosen scale (``pick``, Optimal-scale) or averaged over
        the scales (``pick`` None, Multiscale), says cp_GET > cl_GET."""
        if self.cl_get is None:
            raise RuntimeError("T3DVT-GET refines a block only after prepare() has made cl_GET for the cloud")
        per_scale = self.cl_get[batch.ids]
        if pick is None:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", RuntimeWarning)  # no scale defined: NaN
                cl = np.nanmean(per_scale, axis=1)
        else:
            cl = np.take_along_axis(per_scale, np.maximum(pick, 0)[:, None], axis=1)[:, 0]
            cl[pick < 0] = np.nan
        # cp_GET > cl_GET (False where GET is undefined), and only where the voting saliency is
        # defined: a point with too few neighbours in its spheres stays undefined (docs/method.md, "Saliency map")
        corner = ((1.0 - cl) > cl) & ~nan_rows(saliency)
        out = saliency.copy()
        out[corner] = np.column_stack([cl[corner], np.zeros(int(corner.sum())), 1.0 - cl[corner]])
        return out


def cl_get_of_cloud(xyz: NDArray[np.float64], kind: ScaleKind | str, scales: NDArray[Any], *,
                    max_neighbors: int = 512, min_neighbors: int = 3, threshold: float = 0.0,
                    progress: bool | None = False) -> NDArray[np.float64]:
    """(N, S) cl_GET per point (input order) and scale; NaN where GET is undefined.

    Cylindrical neighbourhoods: the neighbour search runs on (x, y, 0).
    """
    from .gradient_energy import line_saliency_of_index  # numba: loaded to compute, not to list plugins
    from ...numerics.neighbors import NeighborIndex

    flat = np.column_stack([xyz[:, 0], xyz[:, 1], np.zeros(len(xyz))])
    index = NeighborIndex(flat, kind, scales, max_neighbors=max_neighbors, min_neighbors=min_neighbors)
    cl = line_saliency_of_index(index, xyz[index.order, 2], threshold=threshold, progress=progress)
    out = np.empty_like(cl)
    out[index.order] = cl
    return out
