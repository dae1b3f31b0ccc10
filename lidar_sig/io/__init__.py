"""Readers and writers at the edges: point-cloud files in, results out.

``read(path)`` picks the reader from the file extension. A format's module, and with it its
library (laspy, h5py, Open3D), is loaded when a file of that format is first read or written,
or one of its names below is first used (PEP 562): the command line starts without them.
"""
from __future__ import annotations

import os
import pkgutil
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import lazy_loader

from ..base.errors import LidarSigError, as_path, special_file
from ..base.progress import step

if TYPE_CHECKING:
    from ..method.cloud import PointCloud
from .atomic import atomic_output, check_output, check_outputs, output_group
from .formats import HDF5_EXTENSIONS, LAS_EXTENSIONS, POINTS, SIGNATURE, extensions, format_of

# name -> the module of this package that defines it, loaded on first use (a format's own
# reader and writer are the format's: lidar_sig.io.formats loads them)
_EXPORTS = {
    "archive_summary": "archive", "load_signature": "archive", "write_archive": "archive", "saliency_fields": "fields",
    "parse_columns": "_text",
}

__all__ = ["read", "write_cloud", "parse_columns", "CLOUD_EXTENSIONS", "atomic_output", "check_output",
           "check_outputs", "output_group", "check_cloud_output", "write_archive", "load_signature",
           "archive_summary", "LAS_EXTENSIONS", "HDF5_EXTENSIONS"]


# every public module of the package, imported when first used as an attribute (io.archive)
_SUBMODULES = tuple(sorted(m.name for m in pkgutil.iter_modules(__path__) if not m.name.startswith("_")))
_lazy_getattr, _lazy_dir, _ = lazy_loader.attach(
    __name__, submodules=_SUBMODULES,
    submod_attrs={m: [n for n, where in _EXPORTS.items() if where == m] for m in set(_EXPORTS.values())})


def __getattr__(name: str) -> Any:
    if name == "CLOUD_EXTENSIONS":  # the installed formats', made when first asked for
        return extensions(POINTS)
    return _lazy_getattr(name)


def __dir__():
    return sorted(set(globals()) | set(_lazy_dir()) | {"CLOUD_EXTENSIONS"})


def read(path: str | os.PathLike[str], *, columns: str | Sequence[str] | None = None) -> PointCloud:
    """Read a point cloud (LAS/LAZ, PLY/PCD, XYZ/TXT/PTS/CSV text, or a format another package
    adds: :mod:`lidar_sig.io.formats`) into a PointCloud.

    ``columns`` names the columns of a text file (see :mod:`lidar_sig.io._text`).
    """
    as_path(path, "read")
    if columns is not None:  # refused here whatever the file, though only text files take them
        from ._text import parse_columns

        columns = parse_columns(columns)
    from .tile_lists import tile_list

    listed = tile_list(path)  # a glob pattern or a .vpc: the one file it names is read
    if listed is not None and len(listed) != 1:
        raise LidarSigError(f"names {len(listed)} tiles, and one point cloud is read here; give one of them (a set of "
                            f"tiles is taken by signature, saliency, compare, changes and catalog)", path=path)
    path = Path(path) if listed is None else listed[0]
    if not path.exists():
        raise LidarSigError("no such file; check the path", path=path)
    if path.is_dir():
        raise LidarSigError("is a folder, not a point-cloud file (a folder of tiles is taken by signature, saliency, "
                            "compare, changes and catalog)", path=path)
    if special_file(path):  # reading it would wait for a writer, maybe forever
        raise LidarSigError(f"is {special_file(path)}, not a regular file; give a point-cloud file", path=path)
    if not os.access(path, os.R_OK):
        raise LidarSigError("cannot be read (permission denied)", path=path)
    fmt = format_of(path)
    if fmt is not None and POINTS in fmt.holds:
        fmt.load("reader")  # its module loaded before the step, whose time is the reading
        with step(f"reading {path.name}", bytes=path.stat().st_size) as s:
            cloud = fmt.read(path, columns=columns)
            s.note(points=len(cloud))
        return cloud
    if fmt is not None and SIGNATURE in fmt.holds:
        from .catalog_file import refuse_catalog

        refuse_catalog(path, "a point cloud")
        raise LidarSigError("is a signature archive, not a point cloud; use it with `lidar-sig compare` "
                            "or lidar_sig.load_signature", path=path)
    ext = path.suffix.lower()
    raise LidarSigError(f"unknown point-cloud format {ext or '(no extension)'!r}; "
                        f"use one of {', '.join(extensions(POINTS))}", path=path)


def check_cloud_output(path: str | os.PathLike[str], cloud: PointCloud) -> None:
    """Refuse, before any work, a cloud that the format of ``path`` cannot hold (see
    :func:`lidar_sig.io.las.check_las_output`)."""
    fmt = format_of(path)
    if fmt is not None and fmt.check is not None:  # LAS/LAZ: its scale must hold the coordinates
        fmt.load("check")(cloud, path)


def write_cloud(path, cloud, saliency, *, scale_kind=None, scale_values=None, overwrite=False, extra=None):
    """Write the cloud with per-point saliency to ``path``, in the format of its extension (the
    table of :mod:`lidar_sig.io.formats`); ``extra`` (a :class:`~lidar_sig.io.fields.Fields`, e.g.
    :func:`lidar_sig.io.fields.change_fields`) adds per-point fields after the saliency's, each
    with its description where the format keeps one."""
    fmt = format_of(path)
    if fmt is None or POINTS not in fmt.holds:
        ext = Path(path).suffix.lower()
        raise LidarSigError(f"cannot write point clouds as {ext or '(no extension)'!r}; use one of "
                            f"{', '.join(extensions(POINTS))}", path=path)
    from .fields import saliency_fields

    fields = saliency_fields(saliency, scale_kind, scale_values)
    if extra:
        fields.update(extra)
    fmt.write(path, cloud, fields, overwrite=overwrite)
