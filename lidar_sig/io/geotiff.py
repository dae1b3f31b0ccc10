"""GeoTIFF output of rasters in a CRS (the change map's bands), through rasterio.

rasterio is an optional extra (``pip install lidar-sig[geo]``): it brings GDAL, which a user who
never writes a GeoTIFF should not have to install. Bands are float32, deflate-compressed, tiled
(256 x 256) when the raster is large enough for tiles to help, with one no-data value and a
description per band (QGIS shows it as the band's name).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import LidarSigError
from .atomic import atomic_output, check_output

#: No-data value of every band (float32): -9999, which tools without NaN support also read.
NODATA = -9999.0
#: Tile side in pixels; rasters smaller than one tile are written in strips.
TILE = 256
GEOTIFF_EXTENSIONS = (".tif", ".tiff")


def rasterio_module():
    """rasterio, or the one-line error saying how to install it."""
    try:
        import rasterio
    except ImportError:
        raise LidarSigError("writing a GeoTIFF needs rasterio: pip install lidar-sig[geo]") from None
    return rasterio


def check_geotiff_output(path, *, overwrite=False):
    """Refuse, before any work, a GeoTIFF output that cannot be written: wrong extension, no
    rasterio, existing file (unless ``overwrite``), missing or read-only folder."""
    if Path(path).suffix.lower() not in GEOTIFF_EXTENSIONS:
        raise LidarSigError("the change map is written as a GeoTIFF: give a .tif file", path=path)
    rasterio_module()
    check_output(path, overwrite=overwrite)


def write_geotiff(path, bands, descriptions, transform, crs, *, overwrite=False, tags=None):
    """Write (rows, cols) float rasters as one GeoTIFF, NaN written as :data:`NODATA`.

    ``transform`` is (a, b, c, d, e, f) in rasterio's order; ``crs`` WKT or any text pyproj
    reads, or None (no CRS written); ``tags`` a dict of text metadata of the dataset (GDAL
    metadata items: ``gdalinfo`` and QGIS show them, rasterio's ``tags()`` reads them).
    """
    rasterio = rasterio_module()
    from affine import Affine

    data = np.stack([np.where(np.isnan(b), NODATA, b) for b in bands]).astype(np.float32)
    count, rows, cols = data.shape
    profile = {"driver": "GTiff", "width": cols, "height": rows, "count": count, "dtype": "float32",
               "nodata": NODATA, "transform": Affine(*transform), "compress": "deflate", "predictor": 3}
    if rows >= TILE and cols >= TILE:
        profile.update(tiled=True, blockxsize=TILE, blockysize=TILE)
    if crs is not None:
        profile["crs"] = rasterio.crs.CRS.from_user_input(crs)
    with atomic_output(path, overwrite=overwrite) as tmp:
        try:
            with rasterio.open(tmp, "w", **profile) as dst:
                dst.write(data)
                if tags:
                    dst.update_tags(**{str(k): str(v) for k, v in tags.items()})
                for k, text in enumerate(descriptions, 1):
                    dst.set_band_description(k, text)
        except rasterio.errors.RasterioIOError as exc:
            raise LidarSigError(f"could not be written: {str(exc).splitlines()[0]}", path=path) from None
