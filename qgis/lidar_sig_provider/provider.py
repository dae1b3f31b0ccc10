"""The Processing provider "lidar_sig": its algorithms, its icon, and the setting that says which
``lidar-sig`` executable runs them (:mod:`.settings`)."""
from qgis.core import QgsProcessingProvider

from processing.core.ProcessingConfig import ProcessingConfig, Setting

from .algorithms import ALGORITHMS
from .resources import icon, icon_path
from .settings import EXECUTABLE


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
        for algorithm in ALGORITHMS:
            self.addAlgorithm(algorithm())

    def id(self):
        return "lidarsig"

    def name(self):
        return "lidar_sig"

    def longName(self):  # noqa: N802 - QGIS's name
        return "lidar_sig: signatures of airborne LiDAR point clouds"

    def icon(self):
        return icon("lidar_sig")

    def svgIconPath(self):  # noqa: N802 - QGIS's name
        return icon_path("lidar_sig")

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
