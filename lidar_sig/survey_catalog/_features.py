"""What the metrics need of one tile, computed once when the tile enters the catalogue, so that
comparing a query with every tile is a few vector operations: the Fisher vector of its
signature (delta_FV is then an L2 distance), the colour histogram of its Sas (d_BD-Img and
d_EMD-Img), and, kept with the tile anyway, its Egeom histogram (d_EMD-Info) and class totals
(delta_KL, L1). s_SSIM needs the image Sg, which is made again from the tile's counts when it is
needed (:func:`sg_image`): a 512 x 512 image per tile would make a catalogue of thousands of
tiles large.

Every value is what :func:`lidar_sig.metrics.compare` computes from the signature, with the
catalogue's rendering (``RENDER``) and colour bins (``COLOR_BINS``): compare's defaults.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: Rendering of Sg and Sas for the catalogue's image metrics (compare's default).
RENDER = "smooth"
#: Colour-histogram bins per RGB channel (compare's default).
COLOR_BINS = 8


@dataclass
class Features:
    """The per-tile vectors of N tiles (or of one query, N = 1), row i for tile i.

    fv : (N, D) float64 Fisher vectors of the signatures' positions in the triangle
    color : (N, COLOR_BINS**3) float64 normalized colour histograms of Sas
    egeom : (N, B) int64 Egeom histograms
    totals : (N, C) int64 points of each class (undefined saliency included)
    n_points : (N,) int64 points in each signature (the denominator of Sg's shares)
    """

    fv: np.ndarray
    color: np.ndarray
    egeom: np.ndarray
    totals: np.ndarray
    n_points: np.ndarray

    def __len__(self):
        return len(self.fv)

    def row(self, i):
        """The features of tile ``i`` alone (N = 1)."""
        return Features(self.fv[i:i + 1], self.color[i:i + 1], self.egeom[i:i + 1], self.totals[i:i + 1],
                        self.n_points[i:i + 1])


def signature_features(signature):
    """The :class:`Features` of one signature (N = 1): its Sas rendered as ``RENDER``, then its
    colour histogram within the triangle, and the Fisher vector of its positions."""
    from ..metrics import color_histogram, fisher_vector, triangle_positions

    _, sas = signature.render(RENDER)
    color = color_histogram(sas, signature.frame.mask(), bins=COLOR_BINS)
    fv = fisher_vector(*triangle_positions(signature))
    return Features(fv[None], color[None], np.asarray(signature.egeom_counts, np.int64)[None],
                    np.asarray(signature.class_totals, np.int64)[None], np.array([signature.n_points]))


def sg_image(total, n_points, frame):
    """Sg of a signature in the ``RENDER`` ("smooth") rendering from its all-class count raster
    ``total`` (H, W): the Gaussian smoothing of :func:`lidar_sig.method.signature_raster.smooth_counts`
    (standard deviation ``SMOOTH_BANDWIDTH`` of the triangle's side, cut at four, zero beyond
    the image) applied to the total instead of to each class and summed, by OpenCV, which
    frees the GIL for the threads of a shortlist (equal to rounding, 1e-14 counts), then the
    density :func:`~lidar_sig.method.signature_raster.transfer` of the shares."""
    import cv2

    from ..method.signature_raster import SMOOTH_BANDWIDTH, transfer

    v = frame.vertices
    sigma = SMOOTH_BANDWIDTH * (v[1, 0] - v[2, 0])
    size = 2 * int(4.0 * sigma + 0.5) + 1  # scipy's window at truncate=4, as smooth_counts uses
    smoothed = cv2.GaussianBlur(np.asarray(total, np.float64), (size, size), sigmaX=sigma, sigmaY=sigma,
                                borderType=cv2.BORDER_CONSTANT)
    return transfer(smoothed / max(int(n_points), 1))
