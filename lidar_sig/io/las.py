"""LAS/LAZ through laspy: read into a PointCloud, write per-point saliency as extra dimensions.

Written files keep every original point, dimension, VLR/EVLR and CRS of the source unchanged
and add the saliency dimensions of SPEC 8; dimensions of an earlier run are replaced.
"""
from __future__ import annotations

import copy

import laspy
import numpy as np

from ..cloud import PointCloud
from ..errors import LidarSigError
from .atomic import atomic_output

LAS_EXTENSIONS = (".las", ".laz")

# name -> (LAS extra-bytes type, description of at most 32 bytes). 2-byte integers because
# QGIS drops 1-byte extra dimensions.
SALIENCY_DIMS = {
    "Cl": ("f4", "line-type saliency Cl [0,1]"),
    "Cs": ("f4", "surface-type saliency Cs [0,1]"),
    "Cp": ("f4", "point-type saliency Cp [0,1]"),
    "Egeom": ("f4", "geometric entropy [nats]"),
    "GeomClass": ("u2", "1 line 2 surface 3 point 0 none"),
    "OptimalScale": ("u2", ""),  # description set per run: k, or radius index
}
_OPTIMAL_DESC = {"knn": "k of minimum-entropy scale", "radius": "index of min-entropy radius"}


def read_las(path):
    """Read a LAS/LAZ file; labels are the ASPRS classification codes."""
    try:
        las = laspy.read(path)
    except Exception as exc:  # laspy and lazrs raise many kinds on damaged input
        raise LidarSigError(f"cannot be read as LAS/LAZ ({_reason(exc)}); check that the file "
                            "is complete and really LAS/LAZ", path=path) from None
    if len(las.points) == 0:
        raise LidarSigError("the file holds no points; give a file with points", path=path)
    if len(las.points) != las.header.point_count:
        raise LidarSigError(f"holds {len(las.points)} points but its header says "
                            f"{las.header.point_count}; the file is truncated", path=path)
    xyz = np.column_stack([np.asarray(las.x), np.asarray(las.y), np.asarray(las.z)])
    labels = np.asarray(las.classification, dtype=np.int64)
    if not labels.any():
        labels = None  # class 0 "created, never classified" everywhere: an unlabeled cloud
    return PointCloud(xyz, labels, source=las, path=str(path))


def _reason(exc):
    text = str(exc).strip().splitlines()
    return (text[0] if text else type(exc).__name__)[:160]


def to_lasdata(cloud):
    """A fresh LasData holding the cloud: a copy of the source's, or LAS 1.4 PF6 if none."""
    src = cloud.source
    if isinstance(src, laspy.LasData):
        return laspy.LasData(header=copy.deepcopy(src.header), points=src.points.copy())
    header = laspy.LasHeader(point_format=6, version="1.4")
    header.offsets = np.floor(cloud.xyz.min(axis=0))
    header.scales = np.array([0.001, 0.001, 0.001])
    las = laspy.LasData(header)
    las.x, las.y, las.z = cloud.xyz[:, 0], cloud.xyz[:, 1], cloud.xyz[:, 2]
    if cloud.labels is not None:
        las.classification = cloud.labels.astype(np.uint8)
    return las


def saliency_fields(saliency, scale_kind=None, scale_values=None):
    """Per-point outputs by their LAS names: Cl, Cs, Cp, Egeom (float32), GeomClass (uint16) and,
    for Optimal-scale, OptimalScale (uint16: the chosen k, or the 1-based radius index; 0 where
    undefined). Every writer uses these."""
    fields = {"Cl": saliency.cl.astype(np.float32), "Cs": saliency.cs.astype(np.float32),
              "Cp": saliency.cp.astype(np.float32), "Egeom": saliency.egeom.astype(np.float32),
              "GeomClass": saliency.geom_class.astype(np.uint16)}
    if saliency.optimal_scale is not None:
        chosen = saliency.optimal_scale
        if scale_kind == "knn":
            value = np.where(chosen >= 0, np.asarray(scale_values)[np.maximum(chosen, 0)], 0)
        else:
            value = chosen + 1
        fields["OptimalScale"] = value.astype(np.uint16)
    return fields


def write_las(path, cloud, saliency, *, scale_kind=None, scale_values=None, overwrite=False):
    """Write the cloud with saliency extra dimensions (SPEC 8) to ``path`` (.las or .laz).

    Cl, Cs, Cp, Egeom as float32 (NaN where undefined), GeomClass as uint16; with an
    Optimal-scale result also OptimalScale (uint16): the chosen k for k-nearest scales, the
    1-based radius index for spherical ones, 0 where undefined.
    """
    las = to_lasdata(cloud)
    ours = [n for n in SALIENCY_DIMS if n in set(las.point_format.extra_dimension_names)]
    if ours:  # a re-run replaces instead of duplicating
        las.remove_extra_dims(ours)
    fields = saliency_fields(saliency, scale_kind, scale_values)
    params = []
    for name in fields:
        kind, desc = SALIENCY_DIMS[name]
        if name == "OptimalScale":
            desc = _OPTIMAL_DESC[scale_kind]
        params.append(laspy.ExtraBytesParams(name=name, type=np.dtype(kind), description=desc))
    las.add_extra_dims(params)
    for name, values in fields.items():
        las[name] = values
    compress = str(path).lower().endswith(".laz")
    with atomic_output(path, overwrite=overwrite) as tmp:
        with open(tmp, "wb") as fh:
            las.write(fh, do_compress=compress)
