"""Plugin registry: descriptors and scale strategies found through entry points.

A descriptor is a class with ``name``, ``summary`` and ``saliency(batch) -> (B, S, 3)``
(usually by giving ``eigenvalues(batch)``); a strategy is a class with ``name``, ``summary``,
``default_scales`` and ``combine(per_scale) -> (saliency, chosen)``. Third-party packages add
them under the entry-point groups ``lidar_sig.descriptors`` and ``lidar_sig.strategies``; the
built-ins are registered the same way in this package's own metadata (docs/extending.md; the
other kinds of extension, metrics, formats and commands, are found by
:mod:`lidar_sig.base.extensions` too).
"""
from ._kinds import Descriptor, Strategy
from ..numerics.neighbors import NeighborhoodBatch
from ._registry import PluginKind, available, get_descriptor, get_strategy

__all__ = ["Descriptor", "NeighborhoodBatch", "PluginKind", "Strategy", "available", "get_descriptor", "get_strategy"]
