"""lidar_sig's QGIS plugin: a Processing provider that runs the ``lidar-sig`` command."""


def classFactory(iface):  # noqa: N802 - the name QGIS calls
    """The plugin object QGIS loads (``iface`` is None when QGIS runs without its interface)."""
    from .plugin import LidarSigPlugin

    return LidarSigPlugin(iface)
