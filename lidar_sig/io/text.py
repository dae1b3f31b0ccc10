"""Plain-text point clouds: whitespace- or comma-separated X Y Z [label] per line."""
from __future__ import annotations

import numpy as np

from ..cloud import PointCloud
from ..errors import LidarSigError

TEXT_EXTENSIONS = (".xyz", ".txt", ".pts", ".csv")


def read_text(path):
    """Read X Y Z and, when present, an integer label in column 4.

    Lines starting with ``#`` or ``//`` are comments; a first line that is not numeric is a
    header. ``.pts`` files may start with a point-count line, which is skipped.
    """
    try:
        with open(path, encoding="utf-8") as fh:
            lines = [ln for ln in fh if ln.strip() and not ln.lstrip().startswith(("#", "//"))]
    except UnicodeDecodeError:
        raise LidarSigError("is not a text point cloud (binary content)", path=path) from None
    if lines and not _numeric(lines[0]):
        lines = lines[1:]  # header line
    if lines and len(lines[0].replace(",", " ").split()) == 1:
        lines = lines[1:]  # .pts point count
    if not lines:
        raise LidarSigError("the file holds no points; give a file with points", path=path)
    try:
        data = np.loadtxt(lines, delimiter="," if "," in lines[0] else None, ndmin=2)
    except ValueError as exc:
        raise LidarSigError(f"cannot parse the text columns ({exc}); expected X Y Z [label]",
                            path=path) from None
    if data.shape[1] < 3:
        raise LidarSigError(f"needs at least 3 columns X Y Z, found {data.shape[1]}", path=path)
    labels = None
    if data.shape[1] >= 4 and np.all(np.isfinite(data[:, 3])) and np.all(data[:, 3] == np.round(data[:, 3])):
        labels = data[:, 3].astype(np.int64)
    return PointCloud(data[:, :3], labels, source=None, path=str(path))


def _numeric(line):
    try:
        [float(v) for v in line.replace(",", " ").split()]
    except ValueError:
        return False
    return True
