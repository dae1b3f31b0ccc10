"""The jobs: one library call per thing a user asks for, deciding everything a run decides
(one block or tiles from the memory budget, the work folder, which outputs are checked before
the work), writing its outputs whole or not at all, and returning what it did. The command line
and the QGIS provider only gather options and show the result (docs/python.md, "Jobs"). How a job
runs is an :class:`Execution` (memory budget, tiles, workers, cluster, work folder), given to each
job or left to its default.

>>> import lidar_sig as ls                                              # doctest: +SKIP
>>> ls.jobs.saliency("big.laz", "big_sal.laz")                          # doctest: +SKIP
<SaliencyRun complete; wrote big_sal.laz>
"""
from ..tiling.execution import Execution
from .catalog import CatalogJob, OutliersRun, catalog, outliers
from .changes import ChangesRun, changes
from .compare import CompareRun, compare
from .info import Description, info
from .list_plugins import Plugins, plugins
from .saliency import SaliencyRun, saliency
from .signature import SignatureRun, signature

__all__ = ["CatalogJob", "ChangesRun", "CompareRun", "Description", "Execution", "OutliersRun", "Plugins",
           "SaliencyRun", "SignatureRun", "catalog", "changes", "compare", "info", "outliers", "plugins", "saliency",
           "signature"]
