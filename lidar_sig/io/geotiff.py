"""GeoTIFF output of rasters in a CRS (the change map's bands), through rasterio, as a
Cloud-Optimized GeoTIFF.

rasterio is an optional extra (``pip install lidar-sig[geo]``): it brings GDAL, which a user who
never writes a GeoTIFF should not have to install. Bands are float32, deflate-compressed, with
one no-data value and a description per band (QGIS shows it as the band's name). The file is a
Cloud-Optimized GeoTIFF (GDAL's COG driver): tiles of 256 x 256 px, the main image's directory
first, and internal overviews (nearest neighbour, so that every pixel of an overview is a value
of a cell) halving the raster until it fits in one tile: a map of one tile or less has none.
A viewer then reads any part at any zoom without reading the whole file, also over HTTP.
"""
from __future__ import annotations

import errno
import os
import sys

import numpy as np

from ..base.errors import LidarSigError
from .atomic import atomic_output, check_output

#: No-data value of every band (float32): -9999, which tools without NaN support also read.
NODATA = -9999.0
#: Tile side in pixels of the COG, and the size of its smallest overview.
TILE = 256


def rasterio_module():
    """rasterio, or the one-line error saying how to install it."""
    try:
        import rasterio
    except ImportError:
        raise LidarSigError("writing a GeoTIFF needs rasterio: pip install lidar-sig[geo]") from None
    return rasterio


def check_geotiff_output(path: str | os.PathLike[str], *, overwrite: bool = False) -> None:
    """Refuse, before any work, a GeoTIFF output that cannot be written: wrong extension, no
    rasterio, existing file (unless ``overwrite``), missing or read-only folder."""
    from .formats import RASTER, check_format

    check_format(path, RASTER, said="the change map (a GeoTIFF)")
    rasterio_module()
    check_output(path, overwrite=overwrite)


def write_geotiff(path, bands, descriptions, transform, crs, *, overwrite=False, tags=None):
    """Write (rows, cols) float rasters as one Cloud-Optimized GeoTIFF, NaN written as
    :data:`NODATA`.

    ``transform`` is (a, b, c, d, e, f) in rasterio's order; ``crs`` WKT or any text pyproj
    reads, or None (no CRS written); ``tags`` a dict of text metadata of the dataset (GDAL
    metadata items: ``gdalinfo`` and QGIS show them, rasterio's ``tags()`` reads them).
    """
    rasterio = rasterio_module()
    from affine import Affine
    from rasterio.io import MemoryFile
    from rasterio.shutil import copy

    data = np.stack([np.where(np.isnan(b), NODATA, b) for b in bands]).astype(np.float32)
    count, rows, cols = data.shape
    profile = {"driver": "GTiff", "width": cols, "height": rows, "count": count, "dtype": "float32",
               "nodata": NODATA, "transform": Affine(*transform)}
    if crs is not None:
        profile["crs"] = rasterio.crs.CRS.from_user_input(crs)
    from rasterio._err import CPLE_BaseError  # what GDAL's errors are raised as (no public name)

    from .open3d import c_output

    with atomic_output(path, overwrite=overwrite) as tmp:
        failed = None
        # libtiff prints a failed write (a full disk) on the standard error and may go on: what
        # it prints is caught, and any error ends the write, so that no half-written map is kept
        with c_output() as printed:
            try:
                # the bands, descriptions and tags in memory, then copied as a COG: GDAL lays out a
                # COG (directories first, then overviews, then the image) only when it copies
                with MemoryFile() as memory, memory.open(**profile) as src:
                    src.write(data)
                    if tags:
                        src.update_tags(**{str(k): str(v) for k, v in tags.items()})
                    for k, text in enumerate(descriptions, 1):
                        src.set_band_description(k, text)
                    copy(src, tmp, driver="COG", COMPRESS="DEFLATE", PREDICTOR="YES", BLOCKSIZE=str(TILE),
                         OVERVIEWS="AUTO", OVERVIEW_RESAMPLING="NEAREST")
            except (rasterio.errors.RasterioIOError, CPLE_BaseError) as exc:
                failed = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        said = [ln.strip() for ln in printed[0].splitlines() if "error" in ln.lower() or "no space" in ln.lower()]
        if any("no space left" in ln.lower() for ln in [*said, failed or ""]):
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(path))  # said as every full disk is
        if failed or said:
            raise LidarSigError(f"could not be written: {failed or said[0]}", path=path)
        if printed[0].strip():  # what is not an error (a warning of Python's) is shown as it was
            sys.stderr.write(printed[0])
