"""lidar_sig: augmented semantic signatures of airborne LiDAR point clouds, for comparison.

Sreevalsan-Nair & Mohapatra, "Augmented Semantic Signatures of Airborne LiDAR Point Clouds
for Comparison". A cloud's per-point saliency map (Cl, Cs, Cp), placed in barycentric
coordinates of a fixed triangle, makes an image: the geometric signature Sg, or coloured by
semantic class, the augmented semantic signature Sas; metrics between signatures compare clouds.

The public names below are loaded on first use (PEP 562), so that ``import lidar_sig`` and the
start of the command line are quick and a Ctrl-C at that moment is handled like any other.
"""
__version__ = "0.1.0"

import warnings

from .lazy import lazy_names

# numba probes the TBB threading layer first and warns when an older TBB (such as the one
# Open3D ships) is on the path; it then uses OpenMP or its own work queue, which is all we need.
warnings.filterwarnings("ignore", message=".*The TBB threading layer requires TBB")

# public name -> module that defines it
_EXPORTS = {
    "ASPRS": "classes", "PAPER": "classes", "ClassTable": "classes", "class_table": "classes",
    "PointCloud": "cloud", "LidarSigError": "errors", "load_signature": "io", "read": "io",
    "compare": "metrics", "Pipeline": "pipeline", "Result": "pipeline", "Saliency": "saliency",
    "Scales": "scales", "knn": "scales", "radii": "scales", "Frame": "signature", "Signature": "signature",
    "compare_sources": "comparison", "Comparison": "comparison", "resilience": "sampling",
    "Report": "reporting", "report": "comparison", "changes": "change_map", "ChangeMap": "change_map",
    "run_set": "tiling.run", "SetRun": "tiling.results", "executor": "tiling.execute",
    "saliency_in_tiles": "tiling.core", "Catalog": "catalog",
}
__all__ = sorted(_EXPORTS)


__getattr__, __dir__ = lazy_names(__name__, _EXPORTS)
