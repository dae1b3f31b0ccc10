"""The file formats lidar_sig reads and writes, one :class:`Format` each: its name, extensions,
what it holds, where its reader, writer and check of a cloud are, whether results stream into it.
Known without loading any format's module or library (laspy, h5py, Open3D), so that a job checks
its output names before any work; the code asks this table (:func:`format_of`, :func:`holds`,
:func:`check_format`) what a path is rather than testing extensions itself.
"""
from __future__ import annotations

import importlib
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ..base.errors import LidarSigError

#: What a format can hold.
POINTS, SIGNATURE, IMAGE, RASTER, VECTOR, REPORT = "points", "signature", "image", "raster", "vector", "report"


@dataclass(frozen=True)
class Format:
    """A file format: ``name``, ``extensions`` (lower case), what it ``holds`` (point clouds with
    per-point outputs, signatures, images, rasters, vector layers, reports), its ``reader`` and
    ``writer`` of point clouds as ``"module:function"`` (loaded when first used), its ``check``
    of a cloud before any work (``check(cloud, path)`` refuses one the format cannot hold), and
    whether the per-point results of a run in tiles can be ``streamed`` into it chunk by chunk."""

    name: str
    extensions: tuple[str, ...]
    holds: tuple[str, ...]
    reader: str | None = None
    writer: str | None = None
    streamed: bool = False
    #: Keyword options the reader takes (text files: ``columns``).
    options: tuple[str, ...] = ()
    check: str | None = None

    def load(self, which: str) -> Callable[..., Any]:
        """The format's ``"reader"``, ``"writer"`` or ``"check"`` function, its module imported now."""
        where = getattr(self, which)
        if where is None:
            raise LidarSigError(f"{self.name} files have no point-cloud {which} here")
        module, _, name = where.partition(":")
        return getattr(importlib.import_module(module), name)


FORMATS = (
    Format("LAS/LAZ", (".las", ".laz"), (POINTS,), "lidar_sig.io.las:read_las", "lidar_sig.io.las:write_las",
           streamed=True, check="lidar_sig.io.las:check_las_output"),
    Format("PLY/PCD", (".ply", ".pcd"), (POINTS,), "lidar_sig.io.open3d:read_open3d",
           "lidar_sig.io.open3d:write_open3d"),
    Format("text", (".xyz", ".txt", ".pts", ".csv"), (POINTS,), "lidar_sig.io._text:read_text",
           "lidar_sig.io._text:write_text", options=("columns",)),
    Format("HDF5", (".h5", ".hdf5"), (SIGNATURE,)),
    Format("PNG", (".png",), (IMAGE,)),
    Format("GeoTIFF", (".tif", ".tiff"), (RASTER,)),
    Format("GeoPackage", (".gpkg",), (VECTOR,)),
    Format("HTML", (".html", ".htm"), (REPORT,)),
)


def format_of(path: Any) -> Format | None:
    """The format of ``path`` by its extension (any case), or None."""
    ext = Path(path).suffix.lower()
    return next((f for f in FORMATS if ext in f.extensions), None)


def extensions(holds: str) -> tuple[str, ...]:
    """Every extension of the formats that hold ``holds``."""
    return tuple(e for f in FORMATS if holds in f.holds for e in f.extensions)


def holds(path: Any, what: str) -> bool:
    """Whether the format of ``path`` holds ``what`` (False for an unknown extension)."""
    f = format_of(path)
    return f is not None and what in f.holds


def check_format(path: Any, what: str, *, said: str | None = None) -> Format:
    """The format of ``path``, which must hold ``what``; else a LidarSigError naming the path and
    the extensions that do (``said``: what is written, for the message)."""
    f = format_of(path)
    if f is None or what not in f.holds:
        raise LidarSigError(f"give {' or '.join(extensions(what))} for {said or 'this output'}", path=path)
    return f


LAS_EXTENSIONS = FORMATS[0].extensions
OPEN3D_EXTENSIONS = FORMATS[1].extensions
TEXT_EXTENSIONS = FORMATS[2].extensions
#: The point clouds :func:`lidar_sig.io.read` reads and :func:`lidar_sig.io.write_cloud` writes.
CLOUD_EXTENSIONS = extensions(POINTS)
#: Signature archives and survey catalogues (docs/archive.md).
HDF5_EXTENSIONS = extensions(SIGNATURE)
