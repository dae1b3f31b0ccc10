"""The plugin: registers the Processing provider when QGIS starts Processing, removes it when the
plugin is unloaded."""
from qgis.core import QgsApplication


class LidarSigPlugin:
    def __init__(self, iface):
        self.iface = iface
        self.provider = None

    def initProcessing(self):  # noqa: N802 - QGIS's name
        from .provider import LidarSigProvider

        if self.provider is None:
            self.provider = LidarSigProvider()
            QgsApplication.processingRegistry().addProvider(self.provider)

    def initGui(self):  # noqa: N802 - QGIS's name
        self.initProcessing()

    def unload(self):
        if self.provider is not None:
            QgsApplication.processingRegistry().removeProvider(self.provider)
            self.provider = None
