# The public names of lidar_sig, for static tools (editors, type checkers) and for the lazy
# loading of __init__.py, which reads this file: each name is imported from its module when
# first used, so that `import lidar_sig` and the command line start without numpy.
from . import change_map, data, io, jobs, metrics, plugins, reporting, tiling
from . import survey_catalog as catalog
from .base import errors as errors
from .base import progress as progress
from .base.errors import LidarSigError, LidarSigWarning
from .change_map import ChangeMap, ChangeSeries, changes
from .comparison import Comparison, compare, compare_sources, report
from .io import load_signature, read
from .jobs.resilience import resilience
from .method import signature_raster as signature
from .method.classes import ASPRS, PAPER, ClassTable, class_table
from .method.cloud import PointCloud
from .method.saliency_map import Saliency
from .method.scales import Scales, knn, radii
from .method.signature_raster import Frame, Signature
from .pipeline.flow import Pipeline
from .pipeline.result import Result
from .plugins import Descriptor, Strategy
from .reporting import Report
from .survey_catalog import Catalog, build_catalog
from .tiling.execution import Execution
from .tiling.run_set import run_set
from .tiling._set_run import SetRun

__version__: str

__all__ = ["ASPRS", "PAPER", "Catalog", "ChangeMap", "ChangeSeries", "ClassTable", "Comparison", "Descriptor",
           "Execution", "Frame", "LidarSigError", "LidarSigWarning", "Pipeline", "PointCloud", "Report", "Result",
           "Saliency", "Scales", "SetRun", "Signature", "Strategy", "build_catalog", "catalog", "change_map",
           "changes", "class_table", "compare", "compare_sources", "data", "errors", "io", "jobs", "knn",
           "load_signature", "metrics", "plugins", "progress", "radii", "read", "report", "reporting", "resilience",
           "run_set", "signature", "tiling"]
