"""Base classes of the two plugin kinds."""
from __future__ import annotations

from ..saliency import saliency_from_eigenvalues


class Descriptor:
    """Local geometric descriptor: a neighbourhood batch -> per-scale saliency (SPEC 3).

    Subclasses set ``name`` and ``summary`` and give either ``eigenvalues(batch)``, returning
    the (B, S, 3) eigenvalues (descending, >= 0, NaN where undefined) of the tensor at each
    scale, or override ``saliency(batch)`` directly.
    """

    name = ""
    summary = ""

    def eigenvalues(self, batch):
        raise NotImplementedError(f"descriptor {self.name!r} gives neither eigenvalues nor saliency")

    def saliency(self, batch):
        """(B, S, 3) saliency maps (Cl, Cs, Cp) per scale; NaN rows where undefined."""
        return saliency_from_eigenvalues(self.eigenvalues(batch))

    def params(self):
        """Parameters recorded in result metadata."""
        return {}

    def prepare(self, xyz, kind, scales, *, max_neighbors, min_neighbors, progress=None):
        """Called once per cloud before the blocks, with the centred coordinates (input order)
        and the resolved scales; for descriptors that need cloud-wide passes. ``progress`` is
        the pipeline's progress setting (None: on a terminal only)."""

    def refine(self, batch, saliency):
        """Adjust the strategy's combined (B, 3) saliency of a block; identity by default."""
        return saliency


class Strategy:
    """Scale strategy: per-scale saliency maps -> one saliency map per point (SPEC 4)."""

    name = ""
    summary = ""
    default_scales = None

    def combine(self, per_scale):
        """Return ((B, 3) saliency, (B,) chosen scale index or None)."""
        raise NotImplementedError
