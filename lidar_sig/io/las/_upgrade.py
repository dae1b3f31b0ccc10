"""A LAS 1.0-1.3 file made LAS 1.4, the version that defines extra dimensions: the matching point
format with every dimension's values kept, and the CRS also written as WKT."""
from __future__ import annotations

import laspy
import numpy as np

from ...method.crs import las_crs

# LAS 1.0-1.3 point format -> the LAS 1.4 format with the same dimensions (and more).
FORMAT_14 = {0: 6, 1: 6, 2: 7, 3: 7, 4: 9, 5: 10}
SCAN_ANGLE_UNIT = 0.006  # degrees per step of the LAS 1.4 scan_angle dimension


def upgrade_to_14(las):
    """LAS 1.0-1.3 ``las`` as LAS 1.4 with the matching point format (0/1 -> 6, 2/3 -> 7, 4 -> 9,
    5 -> 10), every dimension's values kept, and notes on the change.

    laspy.convert copies dimensions by name and keeps the header's other fields and the VLRs.
    The one dimension LAS 1.4 renames, scan_angle_rank (whole degrees), becomes scan_angle in
    steps of 0.006 degrees (rounded; rounding back to degrees gives the rank). Classification
    codes and the synthetic, key-point and withheld flags keep their values. The global encoding
    keeps its GPS-time and waveform bits and gets the WKT bit, which LAS 1.4 requires with formats
    6-10 (PDAL, and so QGIS, refuse such a file without it and read its CRS from WKT only): a CRS
    given as GeoTIFF keys is therefore also written as WKT; the keys stay.
    """
    old, version = las.point_format.id, str(las.header.version)
    new = laspy.convert(las, point_format_id=FORMAT_14[old], file_version="1.4")
    if "scan_angle_rank" in las.point_format.dimension_names:
        degrees = np.asarray(las.scan_angle_rank, dtype=np.float64)
        new.scan_angle = np.round(degrees / SCAN_ANGLE_UNIT).astype(np.int16)
    new.header.global_encoding.wkt = True
    notes = [f"LAS {version} input written as LAS 1.4 (point format {old} -> {FORMAT_14[old]}), the "
             "version that defines extra dimensions; every original dimension keeps its values"]
    vlrs = new.header.vlrs
    if vlrs.get("GeoKeyDirectoryVlr") and not vlrs.get("WktCoordinateSystemVlr"):
        wkt = _wkt_from_geotiff(las.header)
        if wkt:
            vlrs.append(laspy.vlrs.known.WktCoordinateSystemVlr(wkt))
        else:
            notes.append("the CRS in the GeoTIFF keys has no EPSG code that could be written as "
                         "WKT; the keys are kept, but PDAL and QGIS will show no CRS")
    return new, notes


def _wkt_from_geotiff(header):
    """OGC WKT 1 (as GDAL and PDAL write it) of the CRS in the GeoTIFF keys, or None
    (compound when a vertical EPSG code is given; see :func:`lidar_sig.method.crs.las_crs`)."""
    crs = las_crs(header)
    return crs.to_wkt(version="WKT1_GDAL") if crs is not None else None
