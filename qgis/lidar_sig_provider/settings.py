"""The provider's setting: which ``lidar-sig`` executable runs the algorithms (empty: ``lidar-sig``
on PATH), so that numba, Open3D and the rest live in their own Python rather than in QGIS's.
Read by the algorithms, declared by the provider; neither imports the other."""
from processing.core.ProcessingConfig import ProcessingConfig

#: The setting's name: the path of the lidar-sig executable.
EXECUTABLE = "LIDAR_SIG_EXECUTABLE"


def executable_setting():
    """The path set in Settings > Options > Processing > Providers > lidar_sig, or None."""
    return ProcessingConfig.getSetting(EXECUTABLE) or None
