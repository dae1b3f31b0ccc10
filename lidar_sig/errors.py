"""Deprecated module path: the errors moved to :mod:`lidar_sig.base.errors`. ``from
lidar_sig.errors import LidarSigError`` still works, with a DeprecationWarning; import from
``lidar_sig.base.errors`` (or take ``lidar_sig.LidarSigError``) instead."""
import warnings

from .base.errors import *  # noqa: F401,F403  (the public names of the old module)
from .base.errors import LidarSigError, LidarSigWarning  # noqa: F401  (named for readers and checkers)

# stacklevel 2: the line that imports this module (warnings skips the import machinery's frames)
warnings.warn("lidar_sig.errors is deprecated: import from lidar_sig.base.errors (or use lidar_sig.LidarSigError)",
              DeprecationWarning, stacklevel=2)
