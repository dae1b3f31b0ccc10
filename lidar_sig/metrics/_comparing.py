"""Every installed metric between two signatures (:func:`compare`), from what each reads of a
signature (:class:`SignatureOperand`)."""
from __future__ import annotations

import functools
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..base.errors import LidarSigError, a_kind, whole_number
from ._fisher import signature_fisher_vector
from ._histograms import MAX_COLOR_BINS
from ._images import color_histogram
from ._registered import tables


class SignatureOperand:
    """What the metrics read of one signature (:class:`~lidar_sig.metrics.Operand`), each made
    when first asked for: Sg and the colour histogram of Sas under ``render`` (``color_bins`` per
    RGB channel, inside the frame's triangle ``mask``), the Egeom histogram, the Fisher vector and
    the class totals; and the ``signature`` itself (a catalogue's tiles give the others, from
    their stored vectors, not this)."""

    def __init__(self, signature: Any, render: str, color_bins: int, mask: NDArray[np.bool_] | None) -> None:
        self.signature, self.render, self.color_bins, self.mask = signature, render, color_bins, mask

    @functools.cached_property
    def _rendered(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        return self.signature.render(self.render)

    @property
    def sg(self) -> NDArray[np.float64]:
        return self._rendered[0]

    @functools.cached_property
    def color(self) -> NDArray[np.float64]:
        return color_histogram(self._rendered[1], self.mask, bins=self.color_bins)

    @property
    def egeom(self) -> NDArray[np.int64]:
        return self.signature.egeom_counts

    @functools.cached_property
    def fv(self) -> NDArray[np.float64]:
        return signature_fisher_vector(self.signature)

    @property
    def totals(self) -> NDArray[np.int64]:
        return self.signature.class_totals


def compare(a: Any, b: Any, *, render: str = "smooth", color_bins: int = 8) -> dict[str, float | None]:
    """Every installed metric between two signatures, as a dict of floats (docs/method.md, "Metrics").

    Keys: those of :data:`lidar_sig.metrics.METRIC_KEYS`, lidar_sig's own first:
    ``bhattacharyya`` (d_BD-Img), ``ssim`` (s_SSIM), ``emd_info`` (d_EMD-Info, nats),
    ``emd_img`` (d_EMD-Img), ``fv`` (delta_FV), ``kl`` (delta_KL) and ``l1`` (L1), then those
    of other packages (docs/extending.md); the metrics that need labels (``kl`` and ``l1``)
    are None when either cloud is unlabeled. The image metrics see Sg and Sas rendered as
    ``render`` (see :mod:`lidar_sig.method.signature_raster`); the semantic ones the class
    counts of every labelled point the run used, its saliency defined or not (withheld and noise
    points left out, ``Signature.class_totals``). Raises LidarSigError when the signatures are
    not comparable (frames, class tables or methods differ).
    """
    from ..method.signature_raster import Signature

    for name, sig in (("a", a), ("b", b)):
        if not isinstance(sig, Signature):
            raise LidarSigError(f"compare takes two signatures (result.signature or load_signature(path)); "
                                f"{name} is {a_kind(sig)}")
    color_bins = whole_number(color_bins, "color_bins (bins per RGB channel)", low=2, high=MAX_COLOR_BINS)
    a.check_comparable(b)
    mask = a.frame.mask()
    one, other = SignatureOperand(a, render, color_bins, mask), SignatureOperand(b, render, color_bins, mask)
    labelled = bool(a.classes.names)
    return {m.key: m.value(one, other) if labelled or not m.needs_labels else None for m in tables()["METRICS"]}
