"""Comparing two clouds, or their archives, with one method (docs/method.md, "Metrics"): `lidar-sig compare`, and
the report of one input or of two compared (:func:`report`).

Both sides must be made the same way: two clouds are computed with one pipeline (the same k, or
the same radii in metres); a cloud compared with an archive is computed the way the archive was
made; two archives must record the same method, class table and frame. The image metrics render
both signatures alike (the counts are lossless, so any rendering can be chosen afterwards).
Warnings say what may make the figures mislead, and nothing else. An input is a path, a
PointCloud, a Signature or a pipeline Result; :class:`Side` holds one as compared and reported.

- :mod:`._sides`: the inputs as compared (:class:`Side`) and their reading and runs
- :mod:`._compared`: :class:`Comparison`, :func:`compare_sources`, :func:`compare`, :func:`report`, the warnings
"""
from ._compared import RADII_TOLERANCE, UNDEFINED_WARNING, Comparison, compare, compare_sources, metric_scales, report
from ._sides import Side, input_name, load_input, side_of

__all__ = ["RADII_TOLERANCE", "UNDEFINED_WARNING", "Comparison", "Side", "compare", "compare_sources", "input_name",
           "load_input", "metric_scales", "report", "side_of"]
