"""Deprecated module path: the errors moved to :mod:`lidar_sig.base.errors`. ``from
lidar_sig.errors import LidarSigError`` still works, with a DeprecationWarning; import from
``lidar_sig.base.errors`` (or take ``lidar_sig.LidarSigError``) instead."""
import sys
import warnings

from .base import errors as _moved

# stacklevel 2: the line that imports this module (warnings skips the import machinery's frames)
warnings.warn("lidar_sig.errors is deprecated: import from lidar_sig.base.errors (or use lidar_sig.LidarSigError)",
              DeprecationWarning, stacklevel=2)
# the old path is the module itself, not a copy: `lidar_sig.errors` stays `lidar_sig.base.errors`
# (the package's public name `errors`), and an error class is the same class under both paths
sys.modules[__name__] = _moved
