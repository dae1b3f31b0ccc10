"""PLY and PCD files, and Open3D point clouds in and out.

Files are read through Open3D's tensor point clouds (float64 coordinates, any attributes) and
written here, binary little-endian, with every attribute of the cloud (see :mod:`.table`):

- PLY: ``x y z`` as double, ``red green blue`` and ``nx ny nz`` as such, every other attribute
  as ``scalar_<name>``, the vertex-property names CloudCompare loads as named scalar fields
  (Open3D reads them too).
- PCD: PCL's names (``rgb`` packed 8-bit colour, ``normal_x``..., ``label``), others as named.

A header comment lists the outputs lidar_sig wrote, so that a re-run replaces them and
nothing else. Open3D is imported only when a file is read or a cloud converted: LAS users do
not pay for it.
"""
from __future__ import annotations

import contextlib
import os
import sys
import tempfile
import warnings

from pathlib import Path

import numpy as np

from ..method.cloud import PointCloud
from ..base.errors import LidarSigError, LidarSigWarning
from .atomic import atomic_output
from .fields import marker, parse_marker
from .formats import OPEN3D_EXTENSIONS  # noqa: F401 (a name of this module too)
from ._table import cloudcompare_name, plain_name, point_table

LABEL_NAMES = ("label", "classification", "class")
UNDEFINED_GREY = 0.5  # colour of undefined saliency in to_open3d: neutral mid grey
# PLY property type of each stored dtype. Open3D's PLY reader (0.17-0.20) skips char, short,
# ushort and uint properties: 8- and 16-bit signed integers are written as int, unsigned 32-bit
# and 64-bit integers as double (exact up to 2**53), uint16 under that name, which it reads.
_PLY_TYPES = {"u1": "uchar", "u2": "uint16", "i4": "int", "f4": "float", "f8": "double"}
_PLY_WIDEN = {"b1": "u1", "i1": "i4", "i2": "i4", "u4": "f8", "i8": "f8", "u8": "f8"}
_PCD_TYPES = {"i": "I", "u": "U", "f": "F"}


def _open3d(path=None):
    try:
        import open3d as o3d
    except ImportError as exc:
        raise LidarSigError(f"this needs open3d ({exc}); install it with `pip install open3d` "
                            "(Debian also needs the system library libusb-1.0-0)", path=path) from None
    o3d.utility.set_verbosity_level(o3d.utility.VerbosityLevel.Error)
    return o3d


def is_open3d(obj):
    """True for an Open3D point cloud, legacy or tensor; does not import Open3D."""
    return type(obj).__module__.startswith("open3d") and type(obj).__name__ == "PointCloud"


def from_open3d(pcd, *, path=None):
    """PointCloud of an Open3D point cloud: positions as float64 coordinates; colours, normals
    and (tensor clouds) every other attribute in ``attributes``; an integer attribute named like
    a label (label, classification, class; also with CloudCompare's ``scalar_`` prefix) becomes
    the labels. ``scalar_`` is dropped from names."""
    if hasattr(pcd, "point"):  # open3d.t.geometry.PointCloud
        attrs = {name: pcd.point[name].numpy() for name in pcd.point}
        xyz = attrs.pop("positions", np.empty((0, 3)))
    else:  # open3d.geometry.PointCloud
        xyz = np.asarray(pcd.points)
        attrs = {}
        if pcd.has_colors():
            attrs["colors"] = np.asarray(pcd.colors)
        if pcd.has_normals():
            attrs["normals"] = np.asarray(pcd.normals)
    if len(xyz) == 0:
        raise LidarSigError("holds no points (no positions); give a cloud with points",
                            path=path or "Open3D point cloud")
    n = len(xyz)
    attributes = {}
    for name, values in attrs.items():
        values = np.array(values).reshape(n, -1)
        plain = plain_name(name) if plain_name(name) not in attrs else name
        attributes[plain] = values[:, 0] if values.shape[1] == 1 else values
    labels = None
    for name in LABEL_NAMES:
        values = attributes.get(name)
        if values is not None and values.ndim == 1 and np.all(values == np.round(values)):
            labels = attributes.pop(name).astype(np.int64)
            break
    return PointCloud(np.asarray(xyz, dtype=np.float64), labels, source=None, path=path,
                      attributes=attributes)


def read_open3d(path):
    """Read a PLY or PCD point cloud (see :func:`from_open3d`).

    What Open3D's readers print (RPly's "Unexpected end of file" and the like) is caught and
    becomes the one-line error of a damaged file, instead of lines of its own on the terminal.
    """
    o3d = _open3d(path)
    if Path(path).suffix.lower() == ".pcd" and not _pcd_header(path):
        # Open3D reads anything as a PCD file without points
        raise LidarSigError("is not a PCD file (it does not start with a PCD header: VERSION, FIELDS, ...); "
                            "check the file", path=path)
    with c_output() as printed:
        pc = o3d.t.io.read_point_cloud(str(path))
    problems = [line.strip() for line in printed[0].splitlines() if line.strip()]
    if problems:
        raise LidarSigError(f"cannot be read as {Path(path).suffix.lstrip('.').upper()} ({problems[0][:160]}); "
                            "check that the file is complete", path=path)
    cloud = from_open3d(pc, path=str(path))
    cloud.previous_outputs = parse_marker(_header_comments(path))
    return cloud


def _pcd_header(path):
    """Whether the file starts as a PCD file does: comment lines (#), then VERSION or FIELDS."""
    try:
        with open(path, "rb") as fh:
            head = fh.read(4096)
    except OSError:
        return True  # the reader says what is wrong
    for line in head.split(b"\n"):
        line = line.strip()
        if line and not line.startswith(b"#"):
            return line.split()[0].upper() in (b"VERSION", b"FIELDS")
    return False


@contextlib.contextmanager
def c_output():
    """Capture what C and C++ code prints on the standard output and error (file descriptors
    1 and 2) during the block; yields a list that holds the text afterwards."""
    sys.stdout.flush()
    sys.stderr.flush()
    saved = [os.dup(1), os.dup(2)]
    printed = []
    with tempfile.TemporaryFile() as sink:
        os.dup2(sink.fileno(), 1)
        os.dup2(sink.fileno(), 2)
        try:
            yield printed
        finally:
            os.dup2(saved[0], 1)
            os.dup2(saved[1], 2)
            for fd in saved:
                os.close(fd)
            sink.seek(0)
            printed.append(sink.read().decode("utf-8", "replace"))


def _header_comments(path):
    """Comment lines of a PLY or PCD header, without their comment mark."""
    comments = []
    with open(path, "rb") as fh:
        for raw in fh:
            line = raw.decode("ascii", "replace").strip()
            if line.startswith("comment "):
                comments.append(line[len("comment "):])
            elif line.startswith("#"):
                comments.append(line.lstrip("# "))
            elif line == "end_header" or line.startswith("DATA") or len(comments) > 100:
                break
    return comments


def write_open3d(path, cloud, fields, *, overwrite=False):
    """Write the cloud and the per-point ``fields`` as PLY or PCD, by the extension of ``path``
    (renamed outputs are told as a LidarSigWarning, as by the LAS writer)."""
    columns, outputs, note = point_table(cloud, fields)
    ply = str(path).lower().endswith(".ply")
    names, arrays = (_ply_columns if ply else _pcd_columns)(columns)
    n = len(cloud)
    arrays = [np.ascontiguousarray(cloud.xyz[:, k]) for k in range(3)] + arrays
    names = ["x", "y", "z"] + names
    record = np.empty(n, dtype=[(f"f{k}", a.dtype.newbyteorder("<")) for k, a in enumerate(arrays)])
    for k, a in enumerate(arrays):
        record[f"f{k}"] = a
    mark = marker(outputs)
    if ply:
        props = "".join(f"property {_PLY_TYPES[a.dtype.str[1:]]} {name}\n" for name, a in zip(names, arrays))
        header = (f"ply\nformat binary_little_endian 1.0\ncomment {mark}\nelement vertex {n}\n"
                  f"{props}end_header\n")
    else:
        header = ("# .PCD v0.7 - Point Cloud Data file format\n"
                  f"# {mark}\nVERSION 0.7\nFIELDS {' '.join(names)}\n"
                  f"SIZE {' '.join(str(a.dtype.itemsize) for a in arrays)}\n"
                  f"TYPE {' '.join(_PCD_TYPES[a.dtype.kind] for a in arrays)}\n"
                  f"COUNT {' '.join('1' for _ in arrays)}\nWIDTH {n}\nHEIGHT 1\n"
                  f"VIEWPOINT 0 0 0 1 0 0 0\nPOINTS {n}\nDATA binary\n")
    with atomic_output(path, overwrite=overwrite) as tmp:
        with open(tmp, "wb") as fh:
            fh.write(header.encode("ascii"))
            fh.write(record.tobytes())
    if note:
        warnings.warn(note, LidarSigWarning, stacklevel=4)  # the caller of Result.write


def _storable(values):
    """64-bit integers as float64 (exact up to 2**53), which every PCD reader takes."""
    values = np.asarray(values)
    return values.astype(np.float64) if values.dtype.kind in "iu" and values.dtype.itemsize > 4 else values


def _ply_columns(columns):
    arrays = [np.asarray(v) for v in columns.values()]
    arrays = [a.astype(_PLY_WIDEN.get(a.dtype.str[1:], a.dtype)) for a in arrays]
    return [cloudcompare_name(name) for name in columns], arrays


def _pcd_columns(columns):
    columns = {k: _storable(v) for k, v in columns.items()}
    rgb = [columns.get(c) for c in ("red", "green", "blue")]
    if all(c is not None for c in rgb) and max(int(c.max()) for c in rgb) <= 255:
        # PCL's packed colour; 16-bit LAS colours above 255 stay as red, green, blue fields
        packed = (rgb[0].astype(np.uint32) << 16) | (rgb[1].astype(np.uint32) << 8) | rgb[2].astype(np.uint32)
        columns = {"rgb": packed, **{k: v for k, v in columns.items() if k not in ("red", "green", "blue")}}
    renamed = {"nx": "normal_x", "ny": "normal_y", "nz": "normal_z"}
    return [renamed.get(k, k) for k in columns], list(columns.values())


def to_open3d(result, *, colors="saliency"):
    """An ``open3d.t.geometry.PointCloud`` of a pipeline Result.

    Positions are the cloud's float64 coordinates; attributes are the per-point outputs (Cl, Cs,
    Cp, Egeom as float32 with NaN where undefined, GeomClass and OptimalScale as int32), ``label``
    (int32) if the cloud is labelled, and the cloud's normals if it has any. ``colors``:
    ``"saliency"`` (default) colours each point (R, G, B) = (Cl, Cs, Cp), so line-, surface- and
    point-like points show red, green and blue, and undefined points mid grey (0.5, 0.5, 0.5);
    ``"cloud"`` keeps the cloud's own colours (8-bit LAS values and 16-bit ones scaled to [0, 1]);
    None sets none.
    """
    from .fields import saliency_fields

    o3d = _open3d()
    cloud, sal = result.cloud, result.saliency
    pc = o3d.t.geometry.PointCloud()
    pc.point.positions = o3d.core.Tensor(np.ascontiguousarray(cloud.xyz), o3d.core.float64)
    fields = saliency_fields(sal, result.metadata.get("scale_kind"), result.metadata.get("scale_values"))
    for name, values in fields.items():
        values = values.astype(np.int32) if values.dtype.kind in "iu" else values.astype(np.float32)
        pc.point[name] = o3d.core.Tensor(values.reshape(-1, 1))
    if cloud.labels is not None:
        pc.point.label = o3d.core.Tensor(cloud.labels.astype(np.int32).reshape(-1, 1))
    normals = cloud.attributes.get("normals")
    if normals is not None:
        pc.point.normals = o3d.core.Tensor(np.ascontiguousarray(normals, dtype=np.float32))
    rgb = None
    if colors == "saliency":
        rgb = np.where(sal.defined[:, None], sal.values, UNDEFINED_GREY)
    elif colors == "cloud":
        rgb = _cloud_colors(cloud)
    elif colors is not None:
        raise LidarSigError(f"colors must be 'saliency', 'cloud' or None, got {colors!r}")
    if rgb is not None:
        pc.point.colors = o3d.core.Tensor(np.ascontiguousarray(rgb, dtype=np.float32))
    return pc


def _cloud_colors(cloud):
    """The cloud's colours in [0, 1], or None if it has none."""
    columns, _, _ = point_table(cloud, {})
    if not all(c in columns for c in ("red", "green", "blue")):
        return None
    rgb = np.column_stack([columns["red"], columns["green"], columns["blue"]]).astype(np.float64)
    if np.asarray(columns["red"]).dtype.kind == "f":
        return rgb
    return rgb / (65535.0 if rgb.max() > 255 else 255.0)
