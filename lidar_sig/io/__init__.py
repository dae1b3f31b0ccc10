"""Readers and writers at the edges: point-cloud files in, results out.

``read(path)`` picks the reader from the file extension.
"""
from __future__ import annotations

import os
from pathlib import Path

from ..errors import LidarSigError
from .atomic import atomic_output, check_output
from .hdf5 import HDF5_EXTENSIONS, archive_summary, load_signature, write_archive
from .las import LAS_EXTENSIONS, read_las, write_las
from .text import TEXT_EXTENSIONS, read_text

__all__ = ["read", "atomic_output", "check_output", "write_las", "write_archive", "load_signature",
           "archive_summary", "LAS_EXTENSIONS", "TEXT_EXTENSIONS", "HDF5_EXTENSIONS"]


def read(path):
    """Read a point cloud (LAS/LAZ, or XYZ/TXT/PTS text) into a PointCloud."""
    path = Path(path)
    if not path.exists():
        raise LidarSigError("no such file; check the path", path=path)
    if path.is_dir():
        raise LidarSigError("is a folder, not a point-cloud file", path=path)
    if not os.access(path, os.R_OK):
        raise LidarSigError("cannot be read (permission denied)", path=path)
    ext = path.suffix.lower()
    if ext in LAS_EXTENSIONS:
        return read_las(path)
    if ext in TEXT_EXTENSIONS:
        return read_text(path)
    if ext in HDF5_EXTENSIONS:
        raise LidarSigError("is a signature archive, not a point cloud; use it with `lidar-sig compare` "
                            "or lidar_sig.load_signature", path=path)
    raise LidarSigError(f"unknown point-cloud format {ext or '(no extension)'!r}; "
                        f"use one of {', '.join(LAS_EXTENSIONS + TEXT_EXTENSIONS)}", path=path)
