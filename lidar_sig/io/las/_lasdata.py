"""The LAS 1.4 LasData written for a cloud: a copy of its LAS source (upgraded from 1.0-1.3,
COPC records dropped), or one made for a cloud read from another format, its attributes as
dimensions; and the check, before any work, that LAS can hold the cloud's values."""
from __future__ import annotations

import copy
import datetime

import laspy
import numpy as np

from ...numerics.bounds import bounds
from ...base.errors import LidarSigError
from .._table import point_table
from ._copc import drop_copc
from ._upgrade import upgrade_to_14


def to_lasdata(cloud):
    """A fresh LAS 1.4 LasData of the cloud, and notes on what changed from the source.

    The source's LasData is copied (LAS 1.0-1.3 upgraded to 1.4, COPC records dropped); a cloud
    without one is made by :func:`_new_lasdata`. The generating software and the
    creation date say lidar_sig and today, as the header of any file a program writes.
    """
    from ... import __version__

    src = cloud.source
    notes = []
    if isinstance(src, laspy.LasData):
        las = laspy.LasData(header=copy.deepcopy(src.header), points=src.points.copy())
        if drop_copc(las.header):
            notes.append("COPC input written without its octree index (its COPC records dropped; same points "
                         "and dimensions, LAS 1.4)")
        if las.header.version.minor < 4:
            las, more = upgrade_to_14(las)
            notes += more
    else:
        las = _new_lasdata(cloud)
        merged = _merged(cloud.xyz, las.header.offsets, las.header.scales)
        if merged:
            notes.append(f"coordinates stored in steps of {', '.join(f'{v:g}' for v in las.header.scales)} (LAS "
                         f"integers over this extent): {merged:,} distinct points now share a location with "
                         "another; write .ply, .pcd or text to keep them apart")
    las.header.generating_software = f"lidar_sig {__version__}"
    las.header.creation_date = datetime.date.today()
    return las, notes


def _new_lasdata(cloud):
    """LAS 1.4 LasData of a cloud read from another format: millimetre scales, point format 6,
    7 with colours, 8 with colours and nir; attributes named like a dimension of the format
    (intensity, return_number, gps_time, ...) fill it when their values fit its type, every
    other one (or one that does not fit, as ``<name>_value``) becomes an extra dimension."""
    # an earlier run's outputs are left out: in LAS they are known as ours by descriptions that
    # a PLY or text file does not keep (its header comment only names them)
    columns, _, _ = point_table(cloud, {}, keep_earlier=False)
    columns.pop("label", None)
    fmt = 6 + ("red" in columns) + ("red" in columns and "nir" in columns)
    header = laspy.LasHeader(point_format=fmt, version="1.4")
    header.offsets, header.scales = las_scaling(cloud.xyz)
    header.global_encoding.wkt = True  # required with point formats 6-10
    if cloud.crs:
        import pyproj

        header.add_crs(pyproj.CRS.from_user_input(cloud.crs))
    standard = set(header.point_format.dimension_names) - {"X", "Y", "Z", "classification"}
    fitting = {n: v for n, v in columns.items() if n in standard and _fits(v, header.point_format.dimension_by_name(n))}
    extra = {(n if n not in standard else f"{n}_value"): v for n, v in columns.items() if n not in fitting}
    header.add_extra_dims([laspy.ExtraBytesParams(name=n, type=_extra_type(v)) for n, v in extra.items()])
    las = laspy.LasData(header)
    las.x, las.y, las.z = cloud.xyz[:, 0], cloud.xyz[:, 1], cloud.xyz[:, 2]
    if cloud.labels is not None:
        las.classification = cloud.labels.astype(np.uint8)
    for name, values in fitting.items():
        dim = header.point_format.dimension_by_name(name)
        las[name] = values if dim.dtype is not None and dim.dtype.kind == "f" else np.asarray(values).astype(np.int64)
    for name, values in extra.items():
        las[name] = values
    return las


def las_scaling(xyz):
    """LAS offsets and scales for coordinates ``xyz``: offsets at the floor of the minimum; per
    axis the step of the coordinates' own decimals (:func:`decimal_steps`: 1e-8 for degrees
    written to eight decimals, 1e-6 for kilometres to the millimetre, millimetres for coarser
    ones), no finer than LAS's 32-bit integers allow over the extent (coordinates far apart get
    a coarser one)."""
    lo, hi = bounds(xyz)
    offsets = np.floor(lo)
    span = np.maximum(hi - offsets, 1e-12)
    coarsest = 10.0 ** np.ceil(np.log10(span / (2**31 - 2)))
    return offsets, np.maximum(coarsest, decimal_steps(xyz))


#: Finest step of coordinates written to LAS by their decimals (beyond: as fine as the extent allows).
FINEST_STEP = 1e-12


def decimal_steps(xyz):
    """(3,) per column the largest power of ten, at most a millimetre, of which every value is a
    multiple (to a thousandth of it: round-off): the decimals the values were written with;
    FINEST_STEP where none is."""
    steps = []
    for k in range(3):
        values = xyz[:, k] - (np.floor(xyz[:, k].min()) if len(xyz) else 0.0)  # small numbers, small round-off
        for d in range(3, int(-np.log10(FINEST_STEP)) + 1):
            scaled = values * 10.0**d
            if np.all(np.abs(scaled - np.round(scaled)) <= 1e-3):
                break
        steps.append(10.0**-d)
    return np.array(steps)


def _merged(xyz, offsets, scales):
    """Points whose location another point takes once the coordinates are LAS integers; none
    when every scale is at most the step of its coordinates' decimals (every value is kept)."""
    if np.all(scales <= decimal_steps(xyz) * (1 + 1e-9)):
        return 0
    stored = np.round((xyz - offsets) / scales)
    return len(np.unique(xyz, axis=0)) - len(np.unique(stored, axis=0))


def check_las_output(cloud, path=None):
    """Refuse, before any work, a cloud whose values a LAS file cannot hold: class codes outside
    0-255 (a cloud from another format; a LAS source's codes are LAS codes already)."""
    if isinstance(cloud.source, laspy.LasData) or cloud.labels is None or not len(cloud.labels):
        return
    lo, hi = int(cloud.labels.min()), int(cloud.labels.max())
    if lo < 0 or hi > 255:
        raise LidarSigError(f"class codes {lo} to {hi} do not fit a LAS classification (0-255); write .ply, "
                            f".pcd or text instead, or relabel the cloud", path=path or cloud.path)


def _fits(values, dim):
    """True if ``values`` are stored exactly in the LAS dimension ``dim``."""
    values = np.asarray(values)
    if dim.dtype is not None and dim.dtype.kind == "f":
        return values.dtype.kind in "iuf"
    return (values.dtype.kind in "iub" or bool(np.all(values == np.round(values)))) and \
        values.min() >= dim.min and values.max() <= dim.max


def _extra_type(values):
    """LAS extra-bytes type of an attribute: its own, bool as uint8."""
    dtype = np.asarray(values).dtype
    return np.dtype(np.uint8) if dtype == bool else dtype
