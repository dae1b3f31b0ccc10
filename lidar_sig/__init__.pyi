# The public names of lidar_sig, for static tools (editors, type checkers) and for the lazy
# loading of __init__.py, which reads this file: each name is imported from its module when
# first used, so that `import lidar_sig` and the command line start without numpy.
from . import (catalog, change_map, data, errors, io, jobs, metrics, plugins, progress, reporting, signature,
               tiling)
from .catalog import Catalog, build_catalog
from .change_map import ChangeMap, ChangeSeries, changes
from .classes import ASPRS, PAPER, ClassTable, class_table
from .cloud import PointCloud
from .comparison import Comparison, compare, compare_sources, report
from .errors import LidarSigError, LidarSigWarning
from .io import load_signature, read
from .pipeline import Pipeline
from .plugins import Descriptor, Strategy
from .reporting import Report
from .result import Result
from .saliency import Saliency
from .sampling import resilience
from .scales import Scales, knn, radii
from .signature import Frame, Signature
from .tiling.execution import Execution
from .tiling.results import SetRun
from .tiling.run import run_set

__version__: str

__all__ = ["ASPRS", "PAPER", "Catalog", "ChangeMap", "ChangeSeries", "ClassTable", "Comparison", "Descriptor",
           "Execution", "Frame", "LidarSigError", "LidarSigWarning", "Pipeline", "PointCloud", "Report", "Result",
           "Saliency", "Scales", "SetRun", "Signature", "Strategy", "build_catalog", "catalog", "change_map",
           "changes", "class_table", "compare", "compare_sources", "data", "errors", "io", "jobs", "knn",
           "load_signature", "metrics", "plugins", "progress", "radii", "read", "report", "reporting", "resilience",
           "run_set", "signature", "tiling"]
