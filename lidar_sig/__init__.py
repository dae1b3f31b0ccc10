"""lidar_sig: augmented semantic signatures of airborne LiDAR point clouds, for comparison.

Sreevalsan-Nair & Mohapatra, "Augmented Semantic Signatures of Airborne LiDAR Point Clouds
for Comparison". A cloud's per-point saliency map (Cl, Cs, Cp), placed in barycentric
coordinates of a fixed triangle, makes an image: the geometric signature Sg, or coloured by
semantic class, the augmented semantic signature Sas; metrics between signatures compare clouds.
"""
__version__ = "0.1.0"

import warnings  # noqa: E402

# numba probes the TBB threading layer first and warns when an older TBB (such as the one
# Open3D ships) is on the path; it then uses OpenMP or its own work queue, which is all we need.
warnings.filterwarnings("ignore", message=".*The TBB threading layer requires TBB")

from .classes import ASPRS, PAPER, ClassTable, class_table  # noqa: E402
from .cloud import PointCloud  # noqa: E402
from .errors import LidarSigError  # noqa: E402
from .io import load_signature, read  # noqa: E402
from .metrics import compare  # noqa: E402
from .pipeline import Pipeline, Result  # noqa: E402
from .reporting import Report, report  # noqa: E402
from .saliency import Saliency  # noqa: E402
from .scales import Scales, knn, radii  # noqa: E402
from .signature import Frame, Signature  # noqa: E402

__all__ = ["ASPRS", "PAPER", "ClassTable", "Frame", "LidarSigError", "Pipeline", "PointCloud",
           "Report", "Result", "Saliency", "Scales", "Signature", "class_table", "compare", "knn",
           "load_signature", "radii", "read", "report"]
