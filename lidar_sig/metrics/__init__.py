"""Comparison metrics between two signatures (docs/method.md, "Metrics"); pure functions returning floats.

Distances are 0 for identical inputs; SSIM is 1. Image work (colour histograms, the SSIM's
Gaussian window) goes through OpenCV, imported on first use so that computing saliency alone
never loads it; tests check it against the numpy, scipy and scikit-image definitions.
"""
from __future__ import annotations

import functools
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..base.errors import LidarSigError, a_kind, whole_number
from ..method.saliency_map import LN3
from ..method.signature_raster import to_uint8

#: Additive (Jeffreys) smoothing of class counts before the KL divergence.
KL_ALPHA = 0.5
#: The cases a value is placed against (docs/comparison.md, the ordering benchmark), nearest first.
REFERENCE_CASES = {
    "rotated": "the same land rotated",
    "resampled": "the same land resampled to 80% or 60% of its points",
    "adjacent": "the adjacent tile of the same survey",
    "another_place": "a tile of another city",
}
#: Values within this of a metric's ``same`` value read as "the same land" (rotated copies give
#: the same value to four decimals).
SAME_WITHIN = 5e-5


@dataclass(frozen=True, repr=False)
class Metric:
    """A metric of :func:`compare`: its key, the paper's name, its range, the value of two
    identical signatures (``same``), whether a larger value means more different, a short
    definition and what it reacts to, in a user's words; ``references``: the lowest and highest
    value the project measured between a tile and the same land resampled, the adjacent tile
    and another city ({case: (low, high)}, the 7 references of docs/comparison.md's ordering
    benchmark with the defaults; a rotated copy gives ``same``); how it is computed (``of``,
    from two :class:`Operand`), whether it ``needs_labels`` (None when a cloud has none), and
    its form over ``rows`` of vectors when it comes from each signature's vectors alone (colour
    histogram, Egeom histogram, Fisher vector, class totals: a catalogue screens every pair
    with it) rather than from images or a transport problem per pair."""

    key: str
    name: str
    range: str
    same: float
    larger_differs: bool
    short: str
    reacts: str
    references: dict = None
    of: Callable[[Any, Any], float] = None
    needs_labels: bool = False
    rows: Callable[[Any, Any], np.ndarray] | None = None

    @property
    def from_vectors(self):
        """Whether the metric has a row-wise form (:attr:`rows`: every row of one set of
        signature vectors against every row of another, a (Q, N) array), so that a catalogue
        screens all its pairs with a few array operations."""
        return self.rows is not None

    @property
    def distance_name(self):
        """The name of :meth:`distance`: "1 - s_SSIM" for s_SSIM, the metric's name for the others."""
        return self.name if self.larger_differs else f"{self.same:g} - {self.name}"

    def distance(self, values):
        """``values`` of this metric as distances from identical clouds, larger meaning more
        different (0 = the same): 1 - s_SSIM for s_SSIM, the values themselves for the others."""
        values = np.asarray(values, dtype=np.float64)
        return values - self.same if self.larger_differs else self.same - values

    def __repr__(self) -> str:
        return f"<Metric {self.name} ({self.key}): {self.range}, {self.same:g} = same>"

    def _oriented(self, value):
        return float(value) if self.larger_differs else self.same - float(value)

    def place(self, value: float) -> tuple[str, str]:
        """The reference case ``value`` is most like (a key of :data:`REFERENCE_CASES`) and a
        phrase saying so. The cases split at the geometric mean of the highest value of one
        case and the lowest of the next (their ranges may overlap); a value within
        :data:`SAME_WITHIN` of ``same`` is "rotated", one above every other city's "beyond"."""
        v = self._oriented(value)
        if abs(v) < SAME_WITHIN:
            return "rotated", f"as the same land, rotated ({self.same:g})"
        cases = list(self.references)
        ranges = [sorted(self._oriented(x) for x in self.references[c]) for c in cases]
        for k, case in enumerate(cases[:-1]):
            if v < (ranges[k][1] * ranges[k + 1][0]) ** 0.5:
                return case, f"like {REFERENCE_CASES[case]} ({self.shown_range(case)})"
        if v > ranges[-1][1]:
            return "beyond", f"beyond {REFERENCE_CASES[cases[-1]]} ({self.shown_range(cases[-1])})"
        return cases[-1], f"like {REFERENCE_CASES[cases[-1]]} ({self.shown_range(cases[-1])})"

    def shown_range(self, case):
        """The range of a reference case as text, e.g. ``0.2187-0.5872``."""
        low, high = self.references[case]
        return f"{low:.4f}-{high:.4f}"

    def scale(self, value):
        """``value`` placed on the project's reference values, as plain values for JSON."""
        case, says = self.place(value)
        return {"name": self.name, "like": case, "says": says, "rotated": self.same,
                **{c: list(r) for c, r in self.references.items()}}


def _references(resampled, adjacent, another_place):
    return {"resampled": resampled, "adjacent": adjacent, "another_place": another_place}


# The references: docs/comparison.md, "Defaults, figure by figure" (7 reference tiles, IGN, AHN3,
# ISPRS; 80% and 60% samples pooled as "resampled"); tests/test_gis_answers.py reads them there.
METRICS = (
    Metric("bhattacharyya", "d_BD-Img", "0 to 1", 0.0, True,
           "Bhattacharyya distance of Sas colour histograms",
           "which semantic classes cover how much of the signature (the colours of Sas), not where",
           _references((0.0381, 0.1967), (0.2187, 0.5872), (0.6450, 0.7772)),
           of=lambda a, b: bhattacharyya(a.color, b.color),
           rows=lambda a, b: bhattacharyya_rows(a.color, b.color)),
    Metric("ssim", "s_SSIM", "-1 to 1", 1.0, False, "structural similarity of Sg images",
           "the shape of the geometric signature Sg: where in the triangle the points lie, locally",
           _references((0.9192, 0.9765), (0.8998, 0.9656), (0.6825, 0.8607)),
           of=lambda a, b: ssim(a.sg, b.sg, a.mask)),
    Metric("emd_info", "d_EMD-Info", "0 to ln 3 (1.10) nats", 0.0, True, "EMD of Egeom histograms (nats)",
           "how mixed the local geometry is (Egeom): e.g. more vegetation or clutter raises it",
           _references((0.0052, 0.0424), (0.0131, 0.1154), (0.0401, 0.3044)),
           of=lambda a, b: emd_info(a.egeom, b.egeom),
           rows=lambda a, b: emd_info_rows(a.egeom, b.egeom)),
    Metric("emd_img", "d_EMD-Img", "0 to 1.73", 0.0, True, "EMD of Sas colour histograms (RGB in [0, 1])",
           "the colours of Sas like d_BD-Img, but a change to a similar colour counts less",
           _references((0.0080, 0.0341), (0.0500, 0.1611), (0.1751, 0.3291)),
           of=lambda a, b: emd_img(a.color, b.color, bins=a.color_bins)),
    Metric("fv", "delta_FV", "0 to 2", 0.0, True, "distance of Fisher vectors of saliency positions",
           "shifts of the points' distribution in the triangle (line-, surface- or point-type), "
           "at the scale of an eighth of its side",
           _references((0.0175, 0.2054), (0.0928, 0.5503), (0.3935, 0.7881)),
           of=lambda a, b: float(np.linalg.norm(a.fv - b.fv)),
           rows=lambda a, b: _cdist(a.fv, b.fv, "euclidean")),
    Metric("kl", "delta_KL", "0 to infinity", 0.0, True, "symmetric KL divergence of class distributions",
           "changes in class shares, strongly where a class is rare in one cloud",
           _references((0.0000, 0.0002), (0.0150, 0.5972), (1.7644, 7.0806)),
           of=lambda a, b: symmetric_kl(a.totals, b.totals), needs_labels=True,
           rows=lambda a, b: symmetric_kl_rows(a.totals, b.totals)),
    Metric("l1", "L1", "0 to 2", 0.0, True, "L1 distance of class distributions",
           "changes in class shares: twice the share of points that would have to change class",
           _references((0.0006, 0.0114), (0.1057, 0.6154), (0.6531, 1.1463)),
           of=lambda a, b: l1_distance(a.totals, b.totals), needs_labels=True,
           rows=lambda a, b: _cdist(_shares(a.totals), _shares(b.totals), "cityblock")),
)
#: Keys of the metrics (of :func:`compare`'s dict), in the order of METRICS: the order of every
#: table of metrics and of the change map's GeoTIFF bands.
METRIC_KEYS = tuple(m.key for m in METRICS)
#: The metrics of class composition (they need labels), None when a cloud is unlabelled.
SEMANTIC_KEYS = tuple(m.key for m in METRICS if m.needs_labels)
#: The paper's name of each metric, by key.
METRIC_NAMES = {m.key: m.name for m in METRICS}
#: Each metric by key.
METRIC = {m.key: m for m in METRICS}


def _shares(counts):
    """Each row of ``counts`` (N, C) divided by its total (rows of zeros stay zeros)."""
    counts = np.asarray(counts, dtype=np.float64)
    return counts / np.maximum(counts.sum(axis=1, keepdims=True), 1e-300)


def _cdist(a, b, kind):
    from scipy.spatial.distance import cdist

    return cdist(a, b, kind)


def bhattacharyya_rows(p, q):
    """d_BD-Img of every histogram of ``p`` (M, B) against every one of ``q`` (N, B): (M, N)."""
    return np.sqrt(np.maximum(0.0, 1.0 - np.sqrt(_shares(p)) @ np.sqrt(_shares(q)).T))


def emd_info_rows(p, q, *, upper=LN3):
    """d_EMD-Info (nats) of every Egeom histogram of ``p`` (M, B) against every one of ``q``
    (N, B), bins of equal width over [0, ``upper``]: (M, N)."""
    cp, cq = np.cumsum(_shares(p), axis=1), np.cumsum(_shares(q), axis=1)
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


def ssim(img_a, img_b, mask=None, *, sigma=1.5, k1=0.01, k2=0.03, data_range=1.0):
    """s_SSIM: mean structural similarity of two grayscale images over ``mask`` (docs/method.md, "Metrics").

    Wang et al. (2004) with a Gaussian window (sigma 1.5 px, truncated at 3.5 sigma as
    scikit-image does), population covariances, K1 0.01, K2 0.03. In [-1, 1]; 1 = identical.
    """
    a = np.asarray(img_a, dtype=np.float64)
    b = np.asarray(img_b, dtype=np.float64)
    if a.shape != b.shape:
        raise ValueError(f"images differ in shape: {a.shape} and {b.shape}")

    def blur(x):
        return gaussian_blur(x, sigma, truncate=3.5)

    mu_a, mu_b = blur(a), blur(b)
    var_a = blur(a * a) - mu_a * mu_a
    var_b = blur(b * b) - mu_b * mu_b
    cov = blur(a * b) - mu_a * mu_b
    c1, c2 = (k1 * data_range) ** 2, (k2 * data_range) ** 2
    s = ((2 * mu_a * mu_b + c1) * (2 * cov + c2)) / ((mu_a ** 2 + mu_b ** 2 + c1) * (var_a + var_b + c2))
    return float(s[mask].mean() if mask is not None else s.mean())


def gaussian_blur(image, sigma, *, truncate=3.5):
    """A 2-D float image convolved with a Gaussian of standard deviation ``sigma`` pixels,
    cut at ``truncate`` sigma, edges mirrored (d c b a | a b c d): scipy's
    ``gaussian_filter(image, sigma, truncate=truncate, mode="reflect")``, computed by OpenCV."""
    import cv2

    radius = int(truncate * sigma + 0.5)  # scipy's rule, so both use the same window
    size = 2 * radius + 1
    return cv2.GaussianBlur(np.asarray(image, dtype=np.float64), (size, size), sigmaX=sigma, sigmaY=sigma,
                            borderType=cv2.BORDER_REFLECT)


def color_histogram(rgb, mask=None, *, bins=8):
    """Normalized 3-D colour histogram (bins per channel, R major) of an RGB image in [0, 1].

    The image is first quantized to 8 bits as stored in PNG; bin = value * bins // 256
    (OpenCV's calcHist over [0, 256)).
    """
    import cv2

    px = to_uint8(rgb)
    m = None if mask is None else np.asarray(mask, dtype=np.uint8)
    hist = cv2.calcHist([px], [0, 1, 2], m, [bins] * 3, [0, 256] * 3).ravel().astype(np.float64)
    return hist / max(hist.sum(), 1.0)


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
    mass), which keeps it small.
    """
    emd = _import_whole("pyemd").emd  # its import (POT, scipy.optimize) lasts half a second: Ctrl-C lands in it

    a = np.asarray(hist_a, dtype=np.float64)
    b = np.asarray(hist_b, dtype=np.float64)
    a, b = a / a.sum(), b / b.sum()
    used = (a > 0) | (b > 0)
    centres = color_bin_centres(bins)[used]
    ground = np.sqrt(((centres[:, None, :] - centres[None, :, :]) ** 2).sum(axis=2))
    return float(max(0.0, emd(a[used], b[used], ground)))


def _import_whole(name):
    """The module ``name``, imported with SIGINT and SIGTERM held until the import is done, then
    acted on as if they came just after it. A signal that lands inside a library's import may
    be swallowed by the library, or turned by a compiled module's initialisation into
    ``ImportError: initialization failed`` (pyemd -> POT -> scipy.optimize's pybind11 modules),
    leaving it half loaded and the run going on or failing with a traceback. Held in the main
    thread only, which alone runs Python's signal handlers."""
    import importlib
    import signal
    import sys
    import threading

    if name in sys.modules or threading.current_thread() is not threading.main_thread():
        return importlib.import_module(name)
    received = []
    previous = {}
    for s in (signal.SIGINT, signal.SIGTERM):
        if signal.getsignal(s) not in (None, signal.SIG_IGN):  # None: a handler set outside Python, kept
            previous[s] = signal.signal(s, lambda signum, frame: received.append(signum))
    try:
        return importlib.import_module(name)
    finally:
        for s, handler in previous.items():
            signal.signal(s, handler)
        if received:
            signal.raise_signal(received[0])  # to the handler of the run (KeyboardInterrupt, Interrupted)


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


def fv_distance(a, b, *, grid=FV_GRID):
    """delta_FV = ||FV_a - FV_b||_2 of two signatures, in [0, 2] (docs/method.md, "Metrics").

    The positions are the occupied pixels' centres weighted by their counts
    (:func:`triangle_positions`), not each point's own barycentric position: half a pixel
    diagonal at most apart, and a function of the counts, so that an archive compares like
    the cloud it was made from."""
    return float(np.linalg.norm(signature_fisher_vector(a, grid=grid) - signature_fisher_vector(b, grid=grid)))


#: Most bins per RGB channel of the colour histograms (d_BD-Img, d_EMD-Img).
MAX_COLOR_BINS = 32


class Operand:
    """What the metrics read of one signature (:attr:`Metric.of`), each made when first asked
    for: Sg and the colour histogram of Sas under ``render`` (``color_bins`` per RGB channel,
    inside the frame's triangle ``mask``), the Egeom histogram, the Fisher vector and the class
    totals. A catalogue gives the same from its stored vectors."""

    def __init__(self, signature, render, color_bins, mask):
        self.signature, self.render, self.color_bins, self.mask = signature, render, color_bins, mask

    @functools.cached_property
    def _rendered(self):
        return self.signature.render(self.render)

    @property
    def sg(self):
        return self._rendered[0]

    @functools.cached_property
    def color(self):
        return color_histogram(self._rendered[1], self.mask, bins=self.color_bins)

    @property
    def egeom(self):
        return self.signature.egeom_counts

    @functools.cached_property
    def fv(self):
        return signature_fisher_vector(self.signature)

    @property
    def totals(self):
        return self.signature.class_totals


def compare(a, b, *, render="smooth", color_bins=8):
    """Every metric between two signatures, as a dict of floats (docs/method.md, "Metrics").

    Keys: ``bhattacharyya`` (d_BD-Img), ``ssim`` (s_SSIM), ``emd_info`` (d_EMD-Info, nats),
    ``emd_img`` (d_EMD-Img), ``fv`` (delta_FV), ``kl`` (delta_KL) and ``l1`` (L1); the metrics
    that need labels (``kl`` and ``l1``) are None when either cloud is unlabeled. The image
    metrics see Sg and Sas rendered as ``render`` (see :mod:`lidar_sig.method.signature_raster`); the semantic
    ones the class counts of every labelled point the run used, its saliency defined or not
    (withheld and noise points left out, ``Signature.class_totals``). Raises LidarSigError when
    the signatures are not comparable (frames, class tables or methods differ).
    """
    from ..method.signature_raster import Signature

    for name, sig in (("a", a), ("b", b)):
        if not isinstance(sig, Signature):
            raise LidarSigError(f"compare takes two signatures (result.signature or load_signature(path)); "
                                f"{name} is {a_kind(sig)}")
    color_bins = whole_number(color_bins, "color_bins (bins per RGB channel)", low=2, high=MAX_COLOR_BINS)
    a.check_comparable(b)
    mask = a.frame.mask()
    one, other = Operand(a, render, color_bins, mask), Operand(b, render, color_bins, mask)
    labelled = bool(a.classes.names)
    return {m.key: m.of(one, other) if labelled or not m.needs_labels else None for m in METRICS}
