"""The file formats lidar_sig reads and writes, one :class:`Format` each: its name, extensions,
what it holds, its reader, writer and check of a cloud, whether results stream into it.

lidar_sig's own are the :class:`Format` objects below, registered under the entry-point group
``lidar_sig.formats`` in its pyproject.toml; another package adds a point-cloud format the same
way (docs/extending.md). The table (:data:`FORMATS`) is made when first needed, without loading
any format's module or library (laspy, h5py, Open3D): a reader or writer named as
``"module:function"`` is imported when first used, so that a job checks its output names before
any work. The code asks this table (:func:`format_of`, :func:`holds`, :func:`check_format`) what
a path is rather than testing extensions itself.
"""
from __future__ import annotations

import importlib
import os
from collections.abc import Callable
from dataclasses import dataclass, replace
from functools import lru_cache
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ..base.errors import LidarSigError, a_kind
from ..base.extensions import Extension, registered

if TYPE_CHECKING:
    from ..method.cloud import PointCloud
    from .fields import Fields

#: What a format can hold.
POINTS, SIGNATURE, IMAGE, RASTER, VECTOR, REPORT = "points", "signature", "image", "raster", "vector", "report"
#: A reader: ``reader(path, **options) -> PointCloud``.
Reader = Callable[..., "PointCloud"]
#: A writer: ``writer(path, cloud, fields, *, overwrite)`` writes the cloud with the per-point
#: ``fields`` (:class:`lidar_sig.io.fields.Fields`), whole or not at all (:func:`lidar_sig.io.atomic_output`).
Writer = Callable[..., None]


@dataclass(frozen=True)
class Format:
    """A file format: ``name``, ``extensions`` (lower case, with the dot), what it ``holds``
    (point clouds with per-point outputs, signatures, images, rasters, vector layers, reports),
    its ``reader`` and ``writer`` of point clouds (functions, or ``"module:function"`` loaded
    when first used), its ``check`` of a cloud before any work (``check(cloud, path)`` refuses one
    the format cannot hold), whether the per-point results of a run in tiles can be ``streamed``
    into it chunk by chunk (LAS/LAZ), and the keyword ``options`` its reader takes (text files:
    ``columns``). ``extension`` says which package registered it (for its errors)."""

    name: str
    extensions: tuple[str, ...]
    holds: tuple[str, ...]
    reader: str | Reader | None = None
    writer: str | Writer | None = None
    streamed: bool = False
    options: tuple[str, ...] = ()
    check: str | Callable[[Any, Any], None] | None = None
    extension: Extension | None = None

    @property
    def built_in(self) -> bool:
        """Whether the format is lidar_sig's own (or made here, not registered by a package)."""
        return self.extension is None or self.extension.built_in

    def load(self, which: str) -> Callable[..., Any]:
        """The format's ``"reader"``, ``"writer"`` or ``"check"`` function, its module imported now."""
        where: str | Callable[..., Any] | None = getattr(self, which)
        if where is None:
            raise LidarSigError(f"{self.name} files have no point-cloud {which} here")
        if callable(where):
            return where
        module, _, name = where.partition(":")
        found: Callable[..., Any] = self._run(f"cannot load its {which} {where!r}",
                                              lambda: getattr(importlib.import_module(module), name), failed="")
        return found

    def read(self, path: str | os.PathLike[str], **options: Any) -> PointCloud:
        """The point cloud in ``path``, read by this format's reader with the ``options`` it takes."""
        from ..method.cloud import PointCloud

        reader = self.load("reader")
        cloud = self._run(f"reading {Path(path).name}", reader, path, **{k: v for k, v in options.items()
                                                                          if k in self.options})
        if not isinstance(cloud, PointCloud):
            raise self._fault(f"reading {Path(path).name} returned {a_kind(cloud)}, not a lidar_sig PointCloud")
        return cloud

    def write(self, path: str | os.PathLike[str], cloud: PointCloud, fields: Fields, *,
              overwrite: bool = False) -> None:
        """Write ``cloud`` with the per-point ``fields`` to ``path`` by this format's writer."""
        self._run(f"writing {Path(path).name}", self.load("writer"), path, cloud, fields, overwrite=overwrite)

    def _run(self, doing: str, function: Callable[..., Any], *args: Any, failed: str = "failed ",
             **kwargs: Any) -> Any:
        if self.extension is None or self.built_in:
            return function(*args, **kwargs)  # lidar_sig's own: a failure is a bug, with its traceback
        return self.extension.run(f"{failed}{doing}", function, *args, **kwargs)  # another package's: one line

    def _fault(self, what: str, exc: BaseException | None = None) -> LidarSigError:
        if self.extension is None:
            return LidarSigError(f"format {self.name} {what}" + (f" ({type(exc).__name__}: {exc})" if exc else ""))
        return self.extension.fault(what, exc)


# .laz first: the compressed file, the one a GIS offers first for an output (the QGIS provider)
LAS = Format("LAS/LAZ", (".laz", ".las"), (POINTS,), "lidar_sig.io.las:read_las", "lidar_sig.io.las:write_las",
             streamed=True, check="lidar_sig.io.las:check_las_output")
PLY_PCD = Format("PLY/PCD", (".ply", ".pcd"), (POINTS,), "lidar_sig.io.open3d:read_open3d",
                 "lidar_sig.io.open3d:write_open3d")
TEXT = Format("text", (".xyz", ".txt", ".pts", ".csv"), (POINTS,), "lidar_sig.io._text:read_text",
              "lidar_sig.io._text:write_text", options=("columns",))
HDF5 = Format("HDF5", (".h5", ".hdf5"), (SIGNATURE,))
PNG = Format("PNG", (".png",), (IMAGE,))
GEOTIFF = Format("GeoTIFF", (".tif", ".tiff"), (RASTER,))
GEOPACKAGE = Format("GeoPackage", (".gpkg",), (VECTOR,))
HTML = Format("HTML", (".html", ".htm"), (REPORT,))
#: lidar_sig's own formats in the order listings show them (the metadata lists entry points by
#: name); other packages' come after.
OWN_ORDER = (LAS, PLY_PCD, TEXT, HDF5, PNG, GEOTIFF, GEOPACKAGE, HTML)

LAS_EXTENSIONS = LAS.extensions
OPEN3D_EXTENSIONS = PLY_PCD.extensions
TEXT_EXTENSIONS = TEXT.extensions
#: Signature archives and survey catalogues (docs/archive.md).
HDF5_EXTENSIONS = HDF5.extensions


def _loaded(extension: Extension) -> Format:
    found = extension.load()
    if not isinstance(found, Format):
        raise extension.fault(f"is {found!r}, not a lidar_sig.io.formats.Format")
    if not found.extensions or not all(isinstance(e, str) and e.startswith(".") and e == e.lower()
                                       for e in found.extensions):
        raise extension.fault(f"gives the extensions {found.extensions!r}: give lower-case extensions with their "
                              "dot, such as ('.npz',)")
    if POINTS in found.holds and (found.reader is None or found.writer is None):
        raise extension.fault("holds points but lacks a reader or a writer of point clouds")
    return replace(found, extension=extension)


@lru_cache(maxsize=None)
def formats() -> tuple[Format, ...]:
    """Every installed format (:data:`FORMATS`): lidar_sig's own, then other packages'; a
    LidarSigError naming both when two claim one extension."""
    order = [f.name for f in OWN_ORDER]
    found = sorted((_loaded(e) for e in registered("format").values()),
                   key=lambda f: order.index(f.name) if f.built_in and f.name in order else len(order))
    claimed: dict[str, Format] = {}
    for f in found:
        for ext in f.extensions:
            if ext in claimed:
                first = claimed[ext]
                raise f._fault(f"claims {ext}, which the format {first.name} "
                               f"({first.extension.distribution if first.extension else 'lidar_sig'}) reads; "
                               "each extension is one format's")
            claimed[ext] = f
    return tuple(found)


def __getattr__(name: str) -> Any:
    # the tables of the installed formats, made when first asked for
    if name == "FORMATS":
        return formats()
    if name == "CLOUD_EXTENSIONS":
        return extensions(POINTS)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


if TYPE_CHECKING:
    #: Every installed format: lidar_sig's own, then other packages'.
    FORMATS: tuple[Format, ...]
    #: The point clouds :func:`lidar_sig.io.read` reads and :func:`lidar_sig.io.write_cloud` writes.
    CLOUD_EXTENSIONS: tuple[str, ...]


def format_of(path: Any) -> Format | None:
    """The format of ``path`` by its extension (any case), or None."""
    ext = Path(path).suffix.lower()
    return next((f for f in formats() if ext in f.extensions), None)


def extensions(holds: str) -> tuple[str, ...]:
    """Every extension of the formats that hold ``holds``."""
    return tuple(e for f in formats() if holds in f.holds for e in f.extensions)


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
