"""Comparison metrics between two signatures (docs/method.md, "Metrics"); pure functions returning floats.

Distances are 0 for identical inputs; SSIM is 1. The metrics are those installed: lidar_sig's
own seven and any another package adds through the entry-point group ``lidar_sig.metrics``
(docs/extending.md), read when :data:`METRICS` (or a table made from it) is first asked for.

- :mod:`._metric`: :class:`Metric`, what a metric declares, and :class:`Operand`, what it reads
- :mod:`._histograms`: class distributions, Egeom and colour histograms (delta_KL, L1,
  d_EMD-Info, d_BD-Img, d_EMD-Img), pair by pair and row by row
- :mod:`._images`: s_SSIM and the colour histogram of Sas (OpenCV)
- :mod:`._fisher`: Fisher vectors (delta_FV)
- :mod:`._builtin`: lidar_sig's own metrics, registered in its pyproject.toml
- :mod:`._registered`: the installed metrics, :mod:`._comparing`: :func:`compare`
"""
from __future__ import annotations

from typing import TYPE_CHECKING, Any

from ._comparing import SignatureOperand, compare
from ._fisher import (FV_BASIS_MAX, FV_GRID, fisher_vector, fv_basis, fv_distance, fv_mixture, fv_rows,
                      signature_fisher_vector, triangle_positions)
from ._histograms import (KL_ALPHA, MAX_COLOR_BINS, bhattacharyya, bhattacharyya_rows, color_bin_centres, emd_img,
                          emd_info, emd_info_rows, l1_distance, l1_rows, shares, symmetric_kl, symmetric_kl_rows)
from ._images import color_histogram, gaussian_blur, ssim
from ._metric import REFERENCE_CASES, SAME_WITHIN, Metric, Operand

if TYPE_CHECKING:  # made from the installed metrics when first asked for (__getattr__ below)
    #: Every installed metric: lidar_sig's own, in the order of every table of metrics and of the
    #: change map's GeoTIFF bands, then other packages'.
    METRICS: tuple[Metric, ...]
    #: Keys of the metrics (of :func:`compare`'s dict), in the order of METRICS.
    METRIC_KEYS: tuple[str, ...]
    #: The metrics of class composition (they need labels), None when a cloud is unlabelled.
    SEMANTIC_KEYS: tuple[str, ...]
    #: The paper's name of each metric, by key.
    METRIC_NAMES: dict[str, str]
    #: Each metric by key.
    METRIC: dict[str, Metric]

__all__ = ["FV_BASIS_MAX", "FV_GRID", "KL_ALPHA", "MAX_COLOR_BINS", "METRIC", "METRICS", "METRIC_KEYS",
           "METRIC_NAMES", "REFERENCE_CASES", "SAME_WITHIN", "SEMANTIC_KEYS", "Metric", "Operand", "SignatureOperand",
           "bhattacharyya", "bhattacharyya_rows", "color_bin_centres", "color_histogram", "compare", "emd_img",
           "emd_info", "emd_info_rows", "fisher_vector", "fv_basis", "fv_distance", "fv_mixture", "fv_rows",
           "gaussian_blur", "l1_distance", "l1_rows", "shares", "signature_fisher_vector", "ssim", "symmetric_kl",
           "symmetric_kl_rows", "triangle_positions"]


def __getattr__(name: str) -> Any:
    from ._registered import tables

    found = tables()
    if name in found:
        return found[name]
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
