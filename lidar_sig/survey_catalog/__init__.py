"""Survey catalogues: one signature per tile of a survey, for quality control of a delivery
(:meth:`Catalog.outliers`: the tiles unlike their neighbours and the survey) and for selecting
data (:meth:`Catalog.similar`: the tiles most like a query), with no registration and no
reference classification. docs/catalog.md describes the design and its costs.

- :mod:`~lidar_sig.survey_catalog._tile`: one tile's signature, footprint and features (a task);
- :mod:`~lidar_sig.survey_catalog._build`: making and growing a catalogue on local processes or Dask;
- :mod:`~lidar_sig.survey_catalog._features` and :mod:`~lidar_sig.survey_catalog._distances`: the per-tile
  vectors, the metrics between tiles, their spreads and the combined distance;
- :mod:`~lidar_sig.survey_catalog._survey`: :class:`Catalog`, an opened catalogue;
- :mod:`~lidar_sig.survey_catalog._similar_tiles`, :mod:`~lidar_sig.survey_catalog._outlier_scores`: the two questions;
- :mod:`~lidar_sig.survey_catalog._footprint`, :mod:`~lidar_sig.survey_catalog._embedding`: hulls and
  neighbours in plan view, the tiles' map by likeness.
"""
from ._build import CatalogRun, build_catalog
from ._survey import Catalog, Distances

__all__ = ["Catalog", "CatalogRun", "Distances", "build_catalog"]
