"""Readers and writers at the edges: point-cloud files in, results out.

``read(path)`` picks the reader from the file extension.
"""
from __future__ import annotations

import os
from pathlib import Path

from ..errors import LidarSigError, as_path
from ..progress import step
from .atomic import atomic_output, check_output, check_outputs, output_group
from .hdf5 import HDF5_EXTENSIONS, archive_summary, load_signature, write_archive
from .fields import saliency_fields
from .las import LAS_EXTENSIONS, check_las_output, read_las, write_las
from .open3d import OPEN3D_EXTENSIONS, read_open3d, write_open3d
from .text import TEXT_EXTENSIONS, parse_columns, read_text, write_text

CLOUD_EXTENSIONS = LAS_EXTENSIONS + OPEN3D_EXTENSIONS + TEXT_EXTENSIONS

__all__ = ["read", "write_cloud", "parse_columns", "CLOUD_EXTENSIONS", "atomic_output", "check_output",
           "check_outputs", "output_group", "check_cloud_output", "write_las", "write_archive", "load_signature",
           "archive_summary", "LAS_EXTENSIONS", "TEXT_EXTENSIONS", "HDF5_EXTENSIONS"]


def read(path, *, columns=None):
    """Read a point cloud (LAS/LAZ, PLY/PCD, XYZ/TXT/PTS/CSV text) into a PointCloud.

    ``columns`` names the columns of a text file (see :mod:`lidar_sig.io.text`).
    """
    as_path(path, "read")
    if isinstance(columns, str):
        columns = parse_columns(columns)
    elif columns is not None:
        columns = parse_columns(",".join(map(str, columns)))
    path = Path(path)
    if not path.exists():
        raise LidarSigError("no such file; check the path", path=path)
    if path.is_dir():
        raise LidarSigError("is a folder, not a point-cloud file", path=path)
    if not os.access(path, os.R_OK):
        raise LidarSigError("cannot be read (permission denied)", path=path)
    ext = path.suffix.lower()
    readers = {**dict.fromkeys(LAS_EXTENSIONS, read_las), **dict.fromkeys(OPEN3D_EXTENSIONS, read_open3d),
               **dict.fromkeys(TEXT_EXTENSIONS, lambda p: read_text(p, columns=columns))}
    if ext in readers:
        with step(f"reading {path.name}", bytes=path.stat().st_size) as s:
            cloud = readers[ext](path)
            s.note(points=len(cloud))
        return cloud
    if ext in HDF5_EXTENSIONS:
        raise LidarSigError("is a signature archive, not a point cloud; use it with `lidar-sig compare` "
                            "or lidar_sig.load_signature", path=path)
    raise LidarSigError(f"unknown point-cloud format {ext or '(no extension)'!r}; "
                        f"use one of {', '.join(CLOUD_EXTENSIONS)}", path=path)


def check_cloud_output(path, cloud):
    """Refuse, before any work, a cloud that the format of ``path`` cannot hold (see
    :func:`lidar_sig.io.las.check_las_output`)."""
    if Path(path).suffix.lower() in LAS_EXTENSIONS:
        check_las_output(cloud, path)


def write_cloud(path, cloud, saliency, *, scale_kind=None, scale_values=None, overwrite=False):
    """Write the cloud with per-point saliency to ``path``, in the format of its extension."""
    ext = Path(path).suffix.lower()
    if ext in LAS_EXTENSIONS:
        return write_las(path, cloud, saliency, scale_kind=scale_kind, scale_values=scale_values,
                         overwrite=overwrite)
    fields = saliency_fields(saliency, scale_kind, scale_values)
    if ext in OPEN3D_EXTENSIONS:
        return write_open3d(path, cloud, fields, overwrite=overwrite)
    if ext in TEXT_EXTENSIONS:
        return write_text(path, cloud, fields, overwrite=overwrite)
    raise LidarSigError(f"cannot write point clouds as {ext or '(no extension)'!r}; use one of "
                        f"{', '.join(CLOUD_EXTENSIONS)}", path=path)
