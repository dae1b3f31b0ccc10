"""The level of detection of a change map: per cell and metric, the score that unchanged land
would give between these two epochs, and whether the cell's score exceeds it (docs/changes.md).

Two parts, combined on the log scale of the scores:

- **Sampling** (per cell): the cell's points of each epoch resampled with replacement at both
  epochs' counts and compared, :data:`REPLICATES` times from each epoch
  (:func:`lidar_sig.change_map._cells.null_metrics`). Their mean ``mu0`` is the score of
  unchanged land sampled as this cell is; ``sigma`` the spread of their logs, from their mean
  and variance as for a lognormal sample (a replicate may be 0).
- **Survey** (over all compared cells): ``l = ln(score / mu0)`` of every cell; its median
  ``beta`` is what differs between the two surveys everywhere (density, noise, sensor, a
  classification scheme), its robust spread ``tau`` (1.4826 x MAD) how much that varies from
  cell to cell.

z = (l - beta) / sqrt(tau² + sigma²), and the level of detection LoD = mu0 exp(beta + z_q
sqrt(tau² + sigma²)) with z_q the one-sided normal quantile of the confidence (1.645 at 95%);
a cell changed significantly when its score exceeds its LoD (z > z_q). tau already holds an
average cell's sampling noise, so an average cell counts it twice: the level is conservative.
With fewer than :data:`MIN_CELLS` compared cells no survey part is estimated (beta = tau = 0).
Pure array functions: no signatures, no files.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from statistics import NormalDist

import numpy as np

from ..base.errors import LidarSigError

#: Default confidence of the significance test (one-sided).
CONFIDENCE = 0.95
#: Bootstrap replicates drawn from each epoch per cell (2 x REPLICATES comparisons).
REPLICATES = 3
#: Fewest compared cells from which the survey part (beta, tau) is estimated.
MIN_CELLS = 8
#: Smallest spreads (log scale): two replicates, or cells all alike, may give a spread of 0.
SPREAD_FLOOR = 0.05
#: Scores and replicates below this are taken as this (logs of identical cells' zeros).
VALUE_FLOOR = 1e-12
#: 1 / Phi^-1(3/4): the MAD of a normal sample times this estimates its standard deviation.
MAD_SCALE = 1.4826


@dataclass(repr=False)
class Level:
    """The level of detection of one metric over a change map's cells, (cells,) arrays NaN
    (``significant`` False) where a cell is not compared.

    ``mu0``: mean replicate score (unchanged land, this cell's sampling); ``sigma``: spread of
    the replicates' logs (sqrt(ln(1 + CV²)) of the replicates); ``z``: how far the cell's score lies above its expected value, in
    spreads; ``lod``: the score above which the cell changed significantly; ``beta``, ``tau``:
    the survey part (median and robust spread of ln(score / mu0) over the compared cells);
    ``survey``: whether it was estimated (at least :data:`MIN_CELLS` cells); ``key``: the
    metric's key (``"height"`` for delta_H), when it is known.
    """

    mu0: np.ndarray
    sigma: np.ndarray
    z: np.ndarray
    lod: np.ndarray
    significant: np.ndarray
    beta: float
    tau: float
    survey: bool
    confidence: float
    key: str = ""

    @property
    def n_compared(self) -> int:
        """Cells compared in this metric (its score and level defined)."""
        return int(np.isfinite(self.lod).sum())

    @property
    def n_significant(self) -> int:
        """Cells whose score exceeds the level."""
        return int(self.significant.sum())

    def survey_text(self) -> str:
        """The survey part in words: beta as a factor and tau, or why there is none."""
        if not self.n_compared:
            return "not compared"
        if not self.survey:
            return f"no survey part (fewer than {MIN_CELLS} cells)"
        return f"beta {self.beta:.3g} (x{np.exp(self.beta):.3g}), tau {self.tau:.3g}"

    def __repr__(self):
        of = f" of {self.key}" if self.key else ""
        return (f"<Level{of} at {self.confidence:.0%}: {self.n_compared} cells compared, {self.n_significant} "
                f"significant; {self.survey_text()}>")

    def lod_at(self, confidence):
        """(cells,) the level of detection at another ``confidence`` (a number between 0 and 1,
        one-sided; NaN where not compared)."""
        if (isinstance(confidence, bool) or not isinstance(confidence, (int, float, np.floating))
                or not 0 < confidence < 1):
            raise LidarSigError(f"the confidence must be a number between 0 and 1 (e.g. 0.95), got {confidence!r}")
        spread = np.sqrt(self.tau ** 2 + self.sigma ** 2)
        return self.mu0 * np.exp(self.beta + quantile(confidence) * spread)


class Levels(dict):
    """{metric key: :class:`Level`} of a change map (``"height"`` for delta_H): a dict that
    prints in one line (each metric's survey part and significant cells) and shows a card (a
    row per metric)."""

    @property
    def confidence(self) -> float:
        return next(iter(self.values())).confidence if self else CONFIDENCE

    def __repr__(self):
        from ..base.views import one_line

        compared = max((v.n_compared for v in self.values()), default=0)
        parts = ", ".join(f"{k} n/a" if not v.n_compared else f"{k} {v.beta:.2g}/{v.tau:.2g} {v.n_significant}"
                          if v.survey else f"{k} {v.n_significant}" for k, v in self.items())
        survey = ("survey part beta/tau, significant cells" if any(v.survey for v in self.values())
                  else f"no survey part (fewer than {MIN_CELLS} cells); significant cells")
        return one_line(f"<Levels at {self.confidence:.0%} of {len(self)} metrics over {compared} cells ({survey}): "
                        f"{parts}>")

    def _repr_html_(self):
        from ..metrics import METRIC_NAMES
        from ..base.views import card
        from ._heights import HEIGHT, HEIGHT_NAME

        names = {**METRIC_NAMES, HEIGHT: HEIGHT_NAME}
        rows = [(k, names.get(k, k), v.n_compared, v.n_significant, *(
                (f"{v.beta:.3f}", f"{np.exp(v.beta):.3g}", f"{v.tau:.3f}") if v.survey else ("-", "-", "-")))
                for k, v in self.items()]
        return card("Levels of detection", [f"every metric's level at {self.confidence:.0%}: the score unchanged land "
                                            "would give; a cell changed significantly above it"],
                    header=("key", "metric", "compared", "significant", "beta", "factor", "tau"), rows=rows,
                    numeric=(2, 3, 4, 5, 6),
                    note="beta: what differs between the surveys everywhere (log scale; the factor exp(beta)); "
                         "tau: how much that varies from cell to cell")


def few_cells_note(n_valid):
    """The warning that ``n_valid`` compared cells, fewer than :data:`MIN_CELLS`, leave the level
    without its survey part; None from :data:`MIN_CELLS` up."""
    if n_valid >= MIN_CELLS:
        return None
    return (f"the level of detection covers sampling noise only: {n_valid} compared cell{'s' if n_valid != 1 else ''}, "
            f"fewer than {MIN_CELLS}, cannot tell what differs between the two surveys everywhere; use smaller cells "
            "(--cell) for more")


def pooled_confidence(confidence, tests):
    """The confidence of each of ``tests`` tests that together keep ``confidence``
    (Bonferroni): 1 - (1 - confidence) / tests, 0.975 each for two tests at 95%."""
    return 1.0 - (1.0 - confidence) / tests


def p_values(z, tests=1):
    """(cells,) the p-value of each cell's larger z over ``tests`` tests (Bonferroni): the
    chance that unchanged land lies this far above its level's centre in any of them,
    min(1, tests x (1 - Phi(z))); NaN where z is. A cell is significant at a confidence
    exactly where its p-value is below 1 - confidence (docs/changes.md, "Significance")."""
    # 1 - Phi(z) = erfc(z / sqrt 2) / 2, by the standard library: scipy.special took 50 ms to
    # load, a tenth of what a change map of two 1 km² tiles spends outside its steps
    tail = np.asarray(np.frompyfunc(math.erfc, 1, 1)(np.asarray(z, dtype=np.float64) / math.sqrt(2.0)), np.float64) / 2
    return np.minimum(1.0, tests * tail)


def q_values(p):
    """(cells,) Benjamini-Hochberg q-values of the p-values ``p`` over the cells where they are
    defined (NaN elsewhere): the least false discovery rate at which a cell would be flagged,
    i.e. the expected share of unchanged land among the cells whose q-value is this or less."""
    p = np.asarray(p, dtype=np.float64)
    q = np.full(p.shape, np.nan)
    defined = np.flatnonzero(np.isfinite(p))
    if not len(defined):
        return q
    order = defined[np.argsort(p[defined], kind="stable")]
    ranked = p[order] * len(order) / np.arange(1, len(order) + 1)
    q[order] = np.minimum(1.0, np.minimum.accumulate(ranked[::-1])[::-1])
    return q


def quantile(confidence):
    """z_q: the one-sided standard normal quantile of ``confidence`` (1.645 at 0.95)."""
    return NormalDist().inv_cdf(confidence)


def sampling_part(null):
    """The sampling part of the level of detection from the replicate scores ``null`` (cells,
    replicates) of unchanged land: per cell the replicates' mean (floored at
    :data:`VALUE_FLOOR`), the spread of their logs and whether every replicate is defined;
    (cells,) arrays, NaN where not every replicate is. Cell by cell, so that work units of a
    survey-scale map (:mod:`~lidar_sig.change_map._units`) give each its cells' part."""
    null = np.asarray(null, dtype=np.float64)
    n = len(null)
    defined = np.isfinite(null).all(axis=1)
    mu0, sigma = np.full(n, np.nan), np.full(n, np.nan)
    replicates = null[defined]
    mean = replicates.mean(axis=1)
    mu0[defined] = np.maximum(mean, VALUE_FLOOR)
    # the spread of the replicates' logs from their mean and variance, as of a lognormal sample
    # (var ln X = ln(1 + CV²)): a replicate of 0, where one epoch's cell holds a single class
    # and compares exactly equal with itself, is a small value here, where its logarithm
    # (floored) made the spread, and the level of detection, thousands of times too large
    with np.errstate(invalid="ignore", divide="ignore"):
        cv2 = np.where(mean > 0, replicates.var(axis=1, ddof=1) / mean ** 2, 0.0)
    sigma[defined] = np.maximum(np.sqrt(np.log1p(cv2)), SPREAD_FLOOR)
    return mu0, sigma, defined


def level_of_detection(scores, null, valid, *, confidence=CONFIDENCE, key=""):
    """The :class:`Level` of one metric.

    ``scores``: (cells,) observed scores, larger = more different (1 - s_SSIM for s_SSIM);
    ``null``: (cells, replicates) the replicate scores of unchanged land, same orientation;
    ``valid``: (cells,) bool, the compared cells (where a metric is undefined, e.g. delta_KL of
    unlabelled epochs, its scores are NaN and nothing is significant); ``key`` names the metric.
    """
    return level_from_sampling(scores, *sampling_part(null), valid, confidence=confidence, key=key)


def level_from_sampling(scores, mu0, sigma, defined, valid, *, confidence=CONFIDENCE, key=""):
    """The :class:`Level` of one metric from each cell's sampling part (:func:`sampling_part`:
    ``mu0``, ``sigma``, ``defined``) and its observed ``scores``; the survey part over all the
    compared cells of the map."""
    scores = np.asarray(scores, dtype=np.float64)
    n = len(scores)
    use = np.asarray(valid, bool) & np.isfinite(scores) & np.asarray(defined, bool)
    z, lod = np.full(n, np.nan), np.full(n, np.nan)
    mu0, sigma = np.where(use, mu0, np.nan), np.where(use, sigma, np.nan)
    significant = np.zeros(n, bool)
    if not use.any():
        return Level(mu0, sigma, z, lod, significant, 0.0, 0.0, False, confidence, key)
    ratio = np.log(np.maximum(scores[use], VALUE_FLOOR) / mu0[use])
    survey = int(use.sum()) >= MIN_CELLS
    if survey:
        beta = float(np.median(ratio))
        tau = max(float(MAD_SCALE * np.median(np.abs(ratio - beta))), SPREAD_FLOOR)
    else:
        beta, tau = 0.0, 0.0
    spread = np.sqrt(tau ** 2 + sigma[use] ** 2)
    z[use] = (ratio - beta) / spread
    lod[use] = mu0[use] * np.exp(beta + quantile(confidence) * spread)
    significant[use] = scores[use] > lod[use]
    return Level(mu0, sigma, z, lod, significant, beta, tau, survey, confidence, key)
