"""PLY and PCD through Open3D's tensor point clouds (float64 coordinates, any attributes).

Open3D is imported only when such a file is read or written: LAS users do not pay for it.
"""
from __future__ import annotations

import numpy as np

from ..cloud import PointCloud
from ..errors import LidarSigError
from .atomic import atomic_output

OPEN3D_EXTENSIONS = (".ply", ".pcd")
LABEL_NAMES = ("label", "classification", "class", "scalar_label", "scalar_classification")


def _open3d(path):
    try:
        import open3d as o3d
    except ImportError as exc:
        raise LidarSigError(f"PLY and PCD need open3d ({exc}); install it with `pip install open3d` "
                            "(Debian also needs the system library libusb-1.0-0)", path=path) from None
    o3d.utility.set_verbosity_level(o3d.utility.VerbosityLevel.Error)
    return o3d


def read_open3d(path):
    """Read a PLY or PCD point cloud; an integer attribute named like a label becomes labels."""
    o3d = _open3d(path)
    pc = o3d.t.io.read_point_cloud(str(path))
    if "positions" not in pc.point or len(pc.point.positions) == 0:
        raise LidarSigError("holds no points (no vertices with x, y, z); check that the file is a "
                            "complete point cloud", path=path)
    xyz = pc.point.positions.numpy().astype(np.float64)
    attrs = {name: pc.point[name].numpy().reshape(len(xyz), -1) for name in pc.point if name != "positions"}
    labels = None
    for name in LABEL_NAMES:
        if name in attrs and attrs[name].shape[1] == 1:
            values = attrs.pop(name)[:, 0]
            if np.all(values == np.round(values)):
                labels = values.astype(np.int64)
                break
    attributes = {k: v[:, 0] if v.shape[1] == 1 else v for k, v in attrs.items()}
    return PointCloud(xyz, labels, source=None, path=str(path), attributes=attributes)


def write_open3d(path, cloud, fields, *, overwrite=False):
    """Write coordinates (float64), the label (int32) and per-point ``fields`` as attributes."""
    o3d = _open3d(path)
    pc = o3d.t.geometry.PointCloud()
    pc.point.positions = o3d.core.Tensor(np.ascontiguousarray(cloud.xyz), o3d.core.float64)
    if cloud.labels is not None:
        pc.point.label = o3d.core.Tensor(cloud.labels.astype(np.int32).reshape(-1, 1))
    for name, values in fields.items():
        values = np.asarray(values)
        values = values.astype(np.int32) if values.dtype.kind in "iu" else values.astype(np.float32)
        pc.point[name] = o3d.core.Tensor(np.ascontiguousarray(values.reshape(-1, 1)))
    with atomic_output(path, overwrite=overwrite) as tmp:
        if not o3d.t.io.write_point_cloud(str(tmp), pc):
            raise LidarSigError("open3d could not write the file", path=path)
