"""lidar_sig: augmented semantic signatures of airborne LiDAR point clouds, for comparison.

Sreevalsan-Nair & Mohapatra, "Augmented Semantic Signatures of Airborne LiDAR Point Clouds
for Comparison". A cloud's per-point saliency map (Cl, Cs, Cp), placed in barycentric
coordinates of a fixed triangle, makes an image: the geometric signature Sg, or coloured by
semantic class, the augmented semantic signature Sas; metrics between signatures compare clouds.

The public names, listed in ``__init__.pyi`` (which editors and type checkers read), are loaded
on first use (PEP 562, through ``lazy_loader``), so that ``import lidar_sig`` and the start of
the command line are quick and a Ctrl-C at that moment is handled like any other.
"""
__version__ = "0.1.0"

# When this package is the command line starting, Ctrl-C and SIGTERM wait from here until it
# handles them (lidar_sig/start.py); a program that imports lidar_sig is left alone
from . import start

start.hold()

import warnings  # noqa: E402

import lazy_loader  # noqa: E402

# numba probes the TBB threading layer first and warns when an older TBB (such as the one
# Open3D ships) is on the path; it then uses OpenMP or its own work queue, which is all we need.
warnings.filterwarnings("ignore", message=".*The TBB threading layer requires TBB")

__getattr__, __dir__, __all__ = lazy_loader.attach_stub(__name__, __file__)
