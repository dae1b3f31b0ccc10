"""The metrics between tiles of a catalogue, and the one distance that ranks them.

- **Screening metrics** (``SCREENING``: d_BD-Img, d_EMD-Info, delta_FV, delta_KL, L1) come from
  the tiles' vectors (:mod:`lidar_sig.survey_catalog._features`): a query against N tiles, or all N^2
  pairs, is a few array operations. The values are the metrics' own (docs/method.md, "Metrics"), equal to
  :func:`lidar_sig.metrics.compare`'s to rounding (a sum taken in another order); a test checks
  every pair of its catalogue.
- **Image metrics** (``IMAGE``: s_SSIM of Sg, d_EMD-Img of the Sas colour histograms) need an
  image or a transport problem per pair (docs/performance.md): they are computed for a shortlist,
  with the metrics' own functions (:func:`pair_metrics`).
- **The distance** of two tiles is the mean over the metrics of each metric's value, as a
  distance (s_SSIM as 1 - s_SSIM), divided by its **spread**: the median of that metric over the
  catalogue's pairs (all pairs for the screening metrics, pairs of up to ``SPREAD_TILES`` tiles
  for the image metrics), kept in the catalogue. Each metric then weighs alike, whatever its
  range. The **screening distance** is the same mean over the screening metrics alone.
"""
from __future__ import annotations

import numpy as np

from ..metrics import METRIC, METRIC_KEYS, METRICS, SEMANTIC_KEYS

#: Metrics computed from per-tile vectors for every pair (screening), in METRICS' order.
SCREENING = tuple(m.key for m in METRICS if m.from_vectors)
#: Metrics that need images or a transport problem per pair.
IMAGE = tuple(m.key for m in METRICS if not m.from_vectors)
#: The semantic metrics (None for unlabelled tiles, as in compare).
SEMANTIC = SEMANTIC_KEYS
#: Most tiles whose pairs give the spread of an image metric (16 tiles: 120 pairs).
SPREAD_TILES = 16


def as_distance(key, values):
    """A metric's values as distances from identical clouds (0 = same): s_SSIM becomes 1 - s_SSIM
    (:meth:`lidar_sig.metrics.Metric.distance`)."""
    return METRIC[key].distance(values)


def metric_keys(labelled):
    """The metrics a catalogue compares: every registered one, or those that need no labels when unlabelled."""
    return tuple(k for k in METRIC_KEYS if labelled or k not in SEMANTIC)


def screening(query, tiles, labelled=True):
    """Screening metrics between each row of ``query`` (Features, Q rows) and each tile of
    ``tiles`` (Features, N rows), by each metric's row-wise form
    (:attr:`lidar_sig.metrics.Metric.rows`): a dict key -> (Q, N) float64 array."""
    return {m.key: m.between_rows(query, tiles) for m in METRICS
            if m.from_vectors and (labelled or not m.needs_labels)}


def pair_metrics(a, b, sg_a, sg_b, mask, keys):
    """Every metric of ``keys`` between one tile ``a`` and one tile ``b`` (Features of one row
    each; ``sg_a``, ``sg_b`` their Sg images, needed for s_SSIM), computed by the metrics' own
    functions as :func:`lidar_sig.metrics.compare` does."""
    one, other = TileOperand(a, sg_a, mask), TileOperand(b, sg_b, mask)
    return {key: METRIC[key].value(one, other) for key in keys}


class TileOperand:
    """What a metric reads of one tile (a :class:`lidar_sig.metrics.Operand`, as
    :class:`lidar_sig.metrics.SignatureOperand` of a signature), from its stored vectors (Features
    of one row) and its Sg image."""

    def __init__(self, features, sg, mask):
        from ._features import COLOR_BINS

        self.color, self.egeom, self.fv, self.totals = (features.color[0], features.egeom[0], features.fv[0],
                                                        features.totals[0])
        self.sg, self.mask, self.color_bins = sg, mask, COLOR_BINS


def combine(values, spread, keys):
    """The mean over ``keys`` of each metric's values as a distance divided by its spread."""
    return np.mean([as_distance(k, values[k]) / spread[k] for k in keys], axis=0)


def spread_of(values):
    """The spread of a metric over pairs (its values as distances): their median; the mean
    where more than half the pairs are equal, 1 where every pair is."""
    values = np.asarray(values, dtype=np.float64)
    values = values[np.isfinite(values)]
    for statistic in (np.median, np.mean):
        s = float(statistic(values)) if len(values) else 0.0
        if s > 0:
            return s
    return 1.0


def spreads(features, sg_of, mask, labelled=True):
    """The spread of each metric over a catalogue's tiles (``features``, all N rows):
    screening metrics over every pair, image metrics over the pairs of at most
    ``SPREAD_TILES`` tiles evenly spaced in the catalogue's order (``sg_of(i)`` gives tile i's
    Sg). A dict key -> spread."""
    n = len(features)
    out = {}
    if n < 2:
        return {k: 1.0 for k in metric_keys(labelled)}
    upper = np.triu_indices(n, 1)
    for key, matrix in screening(features, features, labelled).items():
        out[key] = spread_of(as_distance(key, matrix[upper]))
    picked = np.unique(np.linspace(0, n - 1, min(n, SPREAD_TILES)).round().astype(int))
    images = {i: sg_of(i) for i in picked}
    pairs = {k: [] for k in IMAGE}
    for x, i in enumerate(picked):
        for j in picked[x + 1:]:
            values = pair_metrics(features.row(i), features.row(j), images[i], images[j], mask, IMAGE)
            for k in IMAGE:
                pairs[k].append(as_distance(k, values[k]))
    for k in IMAGE:
        out[k] = spread_of(pairs[k])
    return {k: out[k] for k in metric_keys(labelled)}
