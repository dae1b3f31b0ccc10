"""Fisher vectors of a signature's saliency positions (docs/method.md, "Metrics", delta_FV): a
fixed mixture of Gaussians over the unit triangle, the gradients of each pixel kept for small
frames."""
from __future__ import annotations

import functools

import numpy as np


#: Fisher-vector mixture: an n x n grid of isotropic Gaussians over the unit triangle.
FV_GRID = 8


def fisher_vector(positions, weights, *, grid=FV_GRID):
    """Fisher vector of weighted 2D positions in the unit triangle (docs/method.md, "Metrics", delta_FV; there the
    positions are a signature's occupied pixel centres, weighted by their counts).

    The mixture is fixed: Gaussians of equal weight centred on a regular ``grid`` x ``grid``
    lattice over [0, 1] x [0, sqrt(3)/2], kept where the centre lies within one spacing of the
    triangle, isotropic with sigma = the spacing (as in 3DmFV). Gradients with respect to the
    weights, means and sigmas (Sanchez et al. 2013), then power (signed square root) and L2
    normalization.
    """
    x = np.asarray(positions, dtype=np.float64)
    w = np.asarray(weights, dtype=np.float64)
    w = w / w.sum()
    gamma, diff, prior = _posteriors(x, grid)
    g_alpha = (w[:, None] * (gamma - prior)).sum(axis=0) / np.sqrt(prior)
    g_mu = np.einsum("m,mk,mkd->kd", w, gamma, diff) / np.sqrt(prior)
    g_sigma = np.einsum("m,mk,mkd->kd", w, gamma, diff ** 2 - 1.0) / np.sqrt(2.0 * prior)
    return _power_normalize(np.concatenate([g_alpha, g_mu.ravel(), g_sigma.ravel()]))


def _posteriors(x, grid):
    """Posteriors (M, K) of the fixed mixture's Gaussians at positions ``x`` (M, 2), the
    positions' offsets from the centres in sigmas (M, K, 2), and the prior 1/K."""
    centres, sigma = fv_mixture(grid)
    prior = 1.0 / len(centres)
    diff = (x[:, None, :] - centres[None, :, :]) / sigma  # (M, K, 2)
    log_p = -0.5 * (diff ** 2).sum(axis=2)
    log_p -= log_p.max(axis=1, keepdims=True)
    gamma = np.exp(log_p)
    gamma /= gamma.sum(axis=1, keepdims=True)
    return gamma, diff, prior


def _power_normalize(fv):
    fv = np.sign(fv) * np.sqrt(np.abs(fv))
    norm = np.linalg.norm(fv)
    return fv / norm if norm > 0 else fv


#: Largest frame (pixels a side) whose per-pixel Fisher-vector gradients are computed once and
#: kept (size^2 x 5K floats: 10 MB at 64 px); larger frames compute them for their occupied
#: pixels on each call.
FV_BASIS_MAX = 64


@functools.lru_cache(maxsize=4)
def fv_basis(frame, grid=FV_GRID):
    """(size^2, 5K) gradient rows of every pixel centre of ``frame`` (row-major): the Fisher
    vector's gradients before power normalization are linear in the weights, so a signature's
    are ``counts.ravel() @ basis / total`` (:func:`signature_fisher_vector`). Read-only."""
    rows, cols = np.divmod(np.arange(frame.size * frame.size), frame.size)
    gamma, diff, prior = _posteriors(_pixel_positions(frame, rows, cols), grid)
    basis = np.concatenate([(gamma - prior) / np.sqrt(prior),
                            (gamma[:, :, None] * diff).reshape(len(gamma), -1) / np.sqrt(prior),
                            (gamma[:, :, None] * (diff ** 2 - 1.0)).reshape(len(gamma), -1) / np.sqrt(2.0 * prior)],
                           axis=1)
    basis.setflags(write=False)
    return basis


def signature_fisher_vector(signature, *, grid=FV_GRID):
    """The Fisher vector of a signature's count-weighted pixel centres (:func:`fisher_vector`
    of :func:`triangle_positions`); through the frame's kept basis (:func:`fv_basis`) when the
    frame is small, the same values to round-off."""
    if signature.frame.size > FV_BASIS_MAX:
        return fisher_vector(*triangle_positions(signature), grid=grid)
    total = signature.total.ravel()
    occupied = np.flatnonzero(total)
    w = total[occupied].astype(np.float64)
    return _power_normalize(w @ fv_basis(signature.frame, grid)[occupied] / w.sum())


def fv_mixture(grid=FV_GRID):
    """Centres (K, 2) and sigma of the fixed Fisher-vector mixture over the unit triangle."""
    spacing = 1.0 / grid
    g = (np.arange(grid) + 0.5) * spacing
    cx, cy = np.meshgrid(g, g * np.sqrt(3.0) / 2.0)
    centres = np.column_stack([cx.ravel(), cy.ravel()])
    # distance to the triangle (0,0), (1,0), (0.5, sqrt(3)/2): inside when all three
    # signed edge distances are >= -spacing
    d_base = centres[:, 1]
    d_left = (np.sqrt(3.0) * centres[:, 0] - centres[:, 1]) / 2.0
    d_right = (np.sqrt(3.0) * (1.0 - centres[:, 0]) - centres[:, 1]) / 2.0
    keep = np.minimum(np.minimum(d_base, d_left), d_right) >= -spacing
    return centres[keep], spacing


def triangle_positions(signature):
    """(P, 2) positions in the unit triangle of the occupied pixel centres, and their counts.

    V_p = (0, 0), V_s = (1, 0), V_l = (1/2, sqrt(3)/2): the barycentric position of each
    pixel, independent of the frame's size.
    """
    total = signature.total
    rows, cols = np.nonzero(total)
    return _pixel_positions(signature.frame, rows, cols), total[rows, cols]


def _pixel_positions(frame, rows, cols):
    v = frame.vertices  # V_l, V_s, V_p in pixels
    side = v[1, 0] - v[2, 0]
    x = (cols + 0.5 - v[2, 0]) / side
    y = (v[2, 1] - (rows + 0.5)) / side
    return np.column_stack([x, y])


def fv_rows(p, q):
    """delta_FV of every Fisher vector of ``p`` (M, D) against every one of ``q`` (N, D): (M, N)."""
    from scipy.spatial.distance import cdist

    return cdist(p, q, "euclidean")


def fv_distance(a, b, *, grid=FV_GRID):
    """delta_FV = ||FV_a - FV_b||_2 of two signatures, in [0, 2] (docs/method.md, "Metrics").

    The positions are the occupied pixels' centres weighted by their counts
    (:func:`triangle_positions`), not each point's own barycentric position: half a pixel
    diagonal at most apart, and a function of the counts, so that an archive compares like
    the cloud it was made from."""
    return float(np.linalg.norm(signature_fisher_vector(a, grid=grid) - signature_fisher_vector(b, grid=grid)))
