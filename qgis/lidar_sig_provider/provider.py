"""The Processing provider "lidar_sig": its algorithms, and the setting that says which
``lidar-sig`` executable runs them (empty: ``lidar-sig`` on PATH), so that numba, Open3D and the
rest live in their own Python rather than in QGIS's."""
from qgis.core import QgsProcessingProvider

from processing.core.ProcessingConfig import ProcessingConfig, Setting

#: The provider's setting: the path of the lidar-sig executable.
EXECUTABLE = "LIDAR_SIG_EXECUTABLE"


def executable_setting():
    """The path set in Settings > Options > Processing > Providers > lidar_sig, or None."""
    return ProcessingConfig.getSetting(EXECUTABLE) or None


class LidarSigProvider(QgsProcessingProvider):
    def load(self):
        ProcessingConfig.settingIcons[self.name()] = self.icon()
        ProcessingConfig.addSetting(Setting(self.name(), EXECUTABLE,
                                            "lidar-sig executable (empty: lidar-sig on PATH)", "",
                                            valuetype=Setting.FILE))
        ProcessingConfig.readSettings()
        self.refreshAlgorithms()
        return True

    def unload(self):
        ProcessingConfig.removeSetting(EXECUTABLE)

    def loadAlgorithms(self):  # noqa: N802 - QGIS's name
        from .algorithms import ALGORITHMS

        for algorithm in ALGORITHMS:
            self.addAlgorithm(algorithm())

    def id(self):
        return "lidarsig"

    def name(self):
        return "lidar_sig"

    def longName(self):  # noqa: N802 - QGIS's name
        return "lidar_sig: signatures of airborne LiDAR point clouds"

    def supportsNonFileBasedOutput(self):  # noqa: N802 - the command writes files
        return False

    def supportedOutputRasterLayerExtensions(self):  # noqa: N802
        return ["tif"]

    def supportedOutputVectorLayerExtensions(self):  # noqa: N802
        return ["gpkg"]

    def defaultRasterFileExtension(self):  # noqa: N802
        return "tif"

    def defaultVectorFileExtension(self, hasGeometry=True):  # noqa: N802, N803
        return "gpkg"
