"""The metrics of counts and histograms (docs/method.md, "Metrics"): class distributions
(delta_KL, L1), Egeom histograms (d_EMD-Info) and Sas colour histograms (d_BD-Img, d_EMD-Img),
pair by pair and, for a catalogue's screening, row by row."""
from __future__ import annotations

import numpy as np

from ..method.saliency_map import LN3

#: Additive (Jeffreys) smoothing of class counts before the KL divergence.
KL_ALPHA = 0.5
#: Most bins per RGB channel of the colour histograms (d_BD-Img, d_EMD-Img).
MAX_COLOR_BINS = 32


def shares(counts):
    """Each row of ``counts`` (N, C) divided by its total (rows of zeros stay zeros)."""
    counts = np.asarray(counts, dtype=np.float64)
    return counts / np.maximum(counts.sum(axis=1, keepdims=True), 1e-300)


def _cdist(a, b, kind):
    from scipy.spatial.distance import cdist

    return cdist(a, b, kind)


def l1_rows(p, q):
    """L1 of every class count vector of ``p`` (M, C) against every one of ``q`` (N, C): (M, N)."""
    return _cdist(shares(p), shares(q), "cityblock")


def bhattacharyya_rows(p, q):
    """d_BD-Img of every histogram of ``p`` (M, B) against every one of ``q`` (N, B): (M, N)."""
    return np.sqrt(np.maximum(0.0, 1.0 - np.sqrt(shares(p)) @ np.sqrt(shares(q)).T))


def emd_info_rows(p, q, *, upper=LN3):
    """d_EMD-Info (nats) of every Egeom histogram of ``p`` (M, B) against every one of ``q``
    (N, B), bins of equal width over [0, ``upper``]: (M, N)."""
    cp, cq = np.cumsum(shares(p), axis=1), np.cumsum(shares(q), axis=1)
    return _cdist(cp[:, :-1], cq[:, :-1], "cityblock") * (upper / np.shape(p)[1])


def symmetric_kl_rows(p, q, *, alpha=KL_ALPHA, chunk=64):
    """delta_KL of every class count vector of ``p`` (M, C) against every one of ``q`` (N, C):
    (M, N), with :func:`symmetric_kl`'s rule (classes empty in both dropped, ``alpha`` added to
    every other count of a pair where a class is empty in one cloud only); ``chunk`` rows of
    ``p`` at a time bound the (chunk, N, C) arrays."""
    p, q = np.asarray(p, np.float64), np.asarray(q, np.float64)
    return np.concatenate([_kl_block(p[r:r + chunk], q, alpha) for r in range(0, len(p), chunk)]
                          ).reshape(len(p), len(q))


def _kl_block(p, q, alpha):
    p, q = p[:, None, :], q[None, :, :]
    keep = (p > 0) | (q > 0)
    smooth = (keep & ((p == 0) | (q == 0))).any(axis=2, keepdims=True)
    p = np.where(keep, p + alpha * smooth, 0.0)
    q = np.where(keep, q + alpha * smooth, 0.0)
    p, q = p / p.sum(axis=2, keepdims=True), q / q.sum(axis=2, keepdims=True)
    with np.errstate(divide="ignore", invalid="ignore"):
        terms = np.where(keep, (p - q) * np.log(p / q), 0.0)
    return terms.sum(axis=2)


def _as_counts(p, q):
    p = np.asarray(p, dtype=np.float64).ravel()
    q = np.asarray(q, dtype=np.float64).ravel()
    if p.shape != q.shape:
        raise ValueError(f"class count vectors differ in length: {p.size} and {q.size}")
    if (p < 0).any() or (q < 0).any() or p.sum() <= 0 or q.sum() <= 0:
        raise ValueError("class counts must be non-negative with a positive total")
    return p, q


def symmetric_kl(p, q, *, alpha=KL_ALPHA):
    """delta_KL = sum_c (p_c - q_c) ln(p_c / q_c) of two class-count vectors (docs/method.md, "Metrics").

    Counts are normalized to distributions. Classes empty in both clouds are dropped; the
    others get ``alpha`` added to every count before normalizing so that a class present in
    one cloud only gives a finite divergence.
    """
    p, q = _as_counts(p, q)
    keep = (p > 0) | (q > 0)
    p, q = p[keep], q[keep]
    if (p == 0).any() or (q == 0).any():
        p, q = p + alpha, q + alpha
    p, q = p / p.sum(), q / q.sum()
    return float(np.sum((p - q) * np.log(p / q)))


def l1_distance(p, q):
    """L1 = sum_c |p_c - q_c| of the normalized class distributions (the paper's "Hamming
    distance of normalized distributions"), in [0, 2]."""
    p, q = _as_counts(p, q)
    return float(np.abs(p / p.sum() - q / q.sum()).sum())


def emd_info(hist_a, hist_b, *, upper=LN3):
    """d_EMD-Info: EMD between two Egeom histograms over [0, ``upper``] nats (docs/method.md, "Metrics").

    Ground distance |c_i - c_j| between bin centres; in one dimension the EMD equals the
    Wasserstein-1 distance, sum_i |F_a(i) - F_b(i)| * bin width of the cumulative
    distributions, which is computed exactly here. In nats, in [0, ln 3].
    """
    a, b = _as_counts(hist_a, hist_b)
    width = upper / a.size
    return float(np.abs(np.cumsum(a / a.sum() - b / b.sum()))[:-1].sum() * width)


def bhattacharyya(hist_a, hist_b):
    """d_BD-Img of two histograms, normalized here: sqrt(1 - sum sqrt(h_a h_b)), in [0, 1]
    (docs/method.md, "Metrics"; OpenCV HISTCMP_BHATTACHARYYA).

    Computed as sqrt(1/2 sum (sqrt h_a - sqrt h_b)^2), equal in exact arithmetic for
    normalized histograms (the squares expand to 1 + 1 - 2 sum sqrt(h_a h_b)): a sum of
    non-negative terms, exactly 0 for equal histograms, where 1 - sum sqrt(h_a h_b) leaves
    round-off of about 1e-16 that the square root lifts to 1e-8.
    """
    a = np.asarray(hist_a, dtype=np.float64)
    b = np.asarray(hist_b, dtype=np.float64)
    diff = np.sqrt(a / a.sum()) - np.sqrt(b / b.sum())
    return float(min(1.0, np.sqrt(0.5 * np.sum(diff * diff))))


def color_bin_centres(bins=8):
    """(bins^3, 3) RGB centres in [0, 1] of the colour histogram's bins, in its order."""
    idx = np.indices((bins, bins, bins)).reshape(3, -1).T
    return (idx + 0.5) / bins


def emd_img(hist_a, hist_b, *, bins=8):
    """d_EMD-Img: EMD between two colour histograms (docs/method.md, "Metrics"), ground distance the Euclidean
    distance between bin centres in RGB scaled to [0, 1]; in [0, sqrt(3)].

    Only bins occupied in either histogram enter the transport problem (the others carry no
    mass), which keeps it small. OpenCV's exact transportation simplex solves it (single
    precision: 1e-6 relative); the pair is given in one order whatever the order of the call,
    so that the distance is exactly symmetric, and equal histograms are exactly 0.
    """
    import cv2

    a = np.asarray(hist_a, dtype=np.float64)
    b = np.asarray(hist_b, dtype=np.float64)
    a, b = a / a.sum(), b / b.sum()
    if np.array_equal(a, b):
        return 0.0
    if b.tobytes() < a.tobytes():
        a, b = b, a
    used = (a > 0) | (b > 0)
    centres = color_bin_centres(bins)[used]
    signature_a = np.column_stack([a[used], centres]).astype(np.float32)
    signature_b = np.column_stack([b[used], centres]).astype(np.float32)
    distance, _, _ = cv2.EMD(signature_a, signature_b, cv2.DIST_L2)
    return float(max(0.0, distance))
