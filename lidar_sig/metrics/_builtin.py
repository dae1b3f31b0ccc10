"""lidar_sig's own metrics (docs/method.md, "Metrics"), each a :class:`~lidar_sig.metrics.Metric`
registered under the entry-point group ``lidar_sig.metrics`` in lidar_sig's pyproject.toml, in
the order of every table of metrics and of the change map's GeoTIFF bands, as another package's
metric is (docs/extending.md)."""
from __future__ import annotations

import numpy as np

from ._fisher import fv_rows
from ._histograms import (bhattacharyya, bhattacharyya_rows, emd_img, emd_info, emd_info_rows, l1_distance, l1_rows,
                          symmetric_kl, symmetric_kl_rows)
from ._images import ssim
from ._metric import Metric


def _references(resampled: tuple[float, float], adjacent: tuple[float, float],
                another_place: tuple[float, float]) -> dict[str, tuple[float, float]]:
    return {"resampled": resampled, "adjacent": adjacent, "another_place": another_place}


# The references: docs/comparison.md, "Defaults, figure by figure" (7 reference tiles, IGN, AHN3,
# ISPRS; 80% and 60% samples pooled as "resampled"); tests/test_gis_answers.py reads them there.
BHATTACHARYYA = Metric("bhattacharyya", "d_BD-Img", "0 to 1", 0.0, True,
                       "Bhattacharyya distance of Sas colour histograms",
                       "which semantic classes cover how much of the signature (the colours of Sas), not where",
                       _references((0.0381, 0.1967), (0.2187, 0.5872), (0.6450, 0.7772)),
                       of=lambda a, b: bhattacharyya(a.color, b.color),
                       rows=lambda a, b: bhattacharyya_rows(a.color, b.color))
SSIM = Metric("ssim", "s_SSIM", "-1 to 1", 1.0, False, "structural similarity of Sg images",
              "the shape of the geometric signature Sg: where in the triangle the points lie, locally",
              _references((0.9192, 0.9765), (0.8998, 0.9656), (0.6825, 0.8607)),
              of=lambda a, b: ssim(a.sg, b.sg, a.mask))
EMD_INFO = Metric("emd_info", "d_EMD-Info", "0 to ln 3 (1.10) nats", 0.0, True, "EMD of Egeom histograms (nats)",
                  "how mixed the local geometry is (Egeom): e.g. more vegetation or clutter raises it",
                  _references((0.0052, 0.0424), (0.0131, 0.1154), (0.0401, 0.3044)),
                  of=lambda a, b: emd_info(a.egeom, b.egeom),
                  rows=lambda a, b: emd_info_rows(a.egeom, b.egeom))
EMD_IMG = Metric("emd_img", "d_EMD-Img", "0 to 1.73", 0.0, True, "EMD of Sas colour histograms (RGB in [0, 1])",
                 "the colours of Sas like d_BD-Img, but a change to a similar colour counts less",
                 _references((0.0080, 0.0341), (0.0500, 0.1611), (0.1751, 0.3291)),
                 of=lambda a, b: emd_img(a.color, b.color, bins=a.color_bins))
FV = Metric("fv", "delta_FV", "0 to 2", 0.0, True, "distance of Fisher vectors of saliency positions",
            "shifts of the points' distribution in the triangle (line-, surface- or point-type), "
            "at the scale of an eighth of its side",
            _references((0.0175, 0.2054), (0.0928, 0.5503), (0.3935, 0.7881)),
            of=lambda a, b: float(np.linalg.norm(a.fv - b.fv)),
            rows=lambda a, b: fv_rows(a.fv, b.fv))
KL = Metric("kl", "delta_KL", "0 to infinity", 0.0, True, "symmetric KL divergence of class distributions",
            "changes in class shares, strongly where a class is rare in one cloud",
            _references((0.0000, 0.0002), (0.0150, 0.5972), (1.7644, 7.0806)),
            of=lambda a, b: symmetric_kl(a.totals, b.totals), needs_labels=True,
            rows=lambda a, b: symmetric_kl_rows(a.totals, b.totals))
L1 = Metric("l1", "L1", "0 to 2", 0.0, True, "L1 distance of class distributions",
            "changes in class shares: twice the share of points that would have to change class",
            _references((0.0006, 0.0114), (0.1057, 0.6154), (0.6531, 1.1463)),
            of=lambda a, b: l1_distance(a.totals, b.totals), needs_labels=True,
            rows=lambda a, b: l1_rows(a.totals, b.totals))

#: lidar_sig's own metrics in the paper's order, which every table of metrics and the change map's
#: GeoTIFF bands follow (the metadata lists entry points by name); other packages' come after.
PAPER_ORDER = (BHATTACHARYYA, SSIM, EMD_INFO, EMD_IMG, FV, KL, L1)
