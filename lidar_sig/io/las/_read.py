"""Reading a LAS/LAZ file into a PointCloud: the points, the ASPRS class codes, the CRS and its
units, and the extra dimensions an earlier lidar_sig run wrote."""
from __future__ import annotations

import os
import warnings

import laspy
import numpy as np

from ...method.cloud import PointCloud
from ...method.crs import las_units
from ...base.errors import LidarSigError, LidarSigWarning, counted, reason
from ..formats import LAS_EXTENSIONS  # noqa: F401 (a name of this module too)
from ._dims import lidar_sig_dims


def read_las(path):
    """Read a LAS/LAZ file; labels are the ASPRS classification codes, ``withheld`` the
    withheld flag (every point format has it)."""
    try:
        las = laspy.read(path)
    except Exception as exc:  # laspy and lazrs raise many kinds on damaged input
        raise LidarSigError(f"cannot be read as LAS/LAZ ({reason(exc)}); check that the file "
                            "is complete and really LAS/LAZ", path=path) from None
    if len(las.points) == 0:
        raise LidarSigError("the file holds no points; give a file with points", path=path)
    if len(las.points) != las.header.point_count:
        raise LidarSigError(f"holds {counted(len(las.points), 'point')} but its header says "
                            f"{las.header.point_count}; the file is truncated", path=path)
    records = _records_in_file(path, las.header)
    if records is not None and records > las.header.point_count:
        warnings.warn(f"{path}: the header counts {counted(las.header.point_count, 'point')} but the file holds "
                      f"{counted(records, 'point record')}; only the header's {las.header.point_count:,} are read (fix the "
                      "header's point count to use them all)", LidarSigWarning, stacklevel=3)
    xyz = las_xyz(las.points)
    labels = np.asarray(las.classification, dtype=np.int64)
    if not labels.any():
        labels = None  # class 0 "created, never classified" everywhere: an unlabeled cloud
    crs, units = las_units(las.header, path=path)
    return PointCloud(xyz, labels, source=las, path=str(path), previous_outputs=lidar_sig_dims(las),
                      crs=crs, units=units, withheld=np.asarray(las.withheld))


def _records_in_file(path, header):
    """Point records an uncompressed LAS file holds, from its size (None for LAZ, where only the
    compressed chunks know): a header may count fewer than there are."""
    if header.are_points_compressed:
        return None
    end = os.path.getsize(path)
    if header.number_of_evlrs and header.start_of_first_evlr:
        end = min(end, header.start_of_first_evlr)
    waveforms = getattr(header, "start_of_waveform_data_packet_record", 0)
    if waveforms and waveforms > header.offset_to_point_data:
        end = min(end, waveforms)
    return max(0, end - header.offset_to_point_data) // header.point_format.size


def las_xyz(points, n=None):
    """(N, 3) float64 coordinates of laspy ``points`` (a chunk, or a LasData's points; the first
    ``n`` only, if given), as laspy scales them: (X x scale) + offset. Filled column by column
    from the records: stacking laspy's scaled views made two temporary arrays a coordinate,
    three times the time (15 against 5 ms for 500,000 points)."""
    array = points.array if n is None else points.array[:n]
    out = np.empty((len(array), 3))
    for j, name in enumerate("XYZ"):
        column = out[:, j]
        np.multiply(array[name], points.scales[j], out=column)
        column += points.offsets[j]
    return out
