"""Writing a cloud with its saliency as a LAS 1.4 file (docs/method.md, "LAS/LAZ output"), whole or
chunk by chunk, atomically; a failed write (a full disk) is reported as such."""
from __future__ import annotations

import contextlib
import copy
import warnings
from concurrent.futures import ThreadPoolExecutor

import laspy
import numpy as np

from ...method.cloud import PointCloud
from ...method.crs import las_units
from ...base.errors import LidarSigError, LidarSigWarning
from ..atomic import atomic_output, stop_if_interrupted
from ._lasdata import check_las_output, to_lasdata
from ._read import las_xyz
from ._copc import without_copc
from ..fields import saliency_fields
from ._dims import add_fields, extend_ranges, set_extra_bytes_ranges


def write_las(path, cloud, fields, *, overwrite=False):
    """Write the cloud with its per-point ``fields`` (:class:`lidar_sig.io.fields.Fields`) as
    extra dimensions (docs/method.md, "LAS/LAZ output") to ``path`` (.las or .laz), LAS 1.4, as every point-cloud writer
    takes them.

    The saliency's: Cl, Cs, Cp, Egeom as float32 (NaN where undefined), GeomClass as uint16 (0
    where undefined); with an Optimal-scale result also OptimalScale (uint16): the chosen k for
    k-nearest scales, the 1-based radius index for spherical ones, 0 where undefined; others
    (the per-point change) in their values' types. NaN and 0 are declared as the dimensions'
    no-data values; their min and max are those of the defined values. What the caller should
    know (an upgraded version, a dropped COPC index, renamed outputs) is issued as a
    :class:`LidarSigWarning` once the file is written.
    """
    check_las_output(cloud, path)
    las, notes = with_fields(cloud, fields)
    with _las_writer(path, las.header, overwrite) as writer:
        writer.write_points(las.points)
        if las.evlrs:
            writer.write_evlrs(las.evlrs)
        # the writer rewrites its header, VLRs included, when it closes
        set_extra_bytes_ranges(writer.header, las.points)
    for text in notes:
        warnings.warn(text, LidarSigWarning, stacklevel=4)  # the caller of Result.write


def with_fields(cloud, fields):
    """The LAS 1.4 LasData written for ``cloud`` (see :func:`lidar_sig.io.las._lasdata.to_lasdata`)
    with the per-point ``fields`` as extra dimensions, and the notes on what changed."""
    las, notes = to_lasdata(cloud)
    notes += add_fields(las, fields, path=cloud.path)
    return las, notes


def write_las_chunks(path, source, saliency_chunks, *, scale_kind=None, scale_values=None, overwrite=False,
                     chunk_points=500_000, extra=None):
    """Write the LAS/LAZ file ``source`` with saliency extra dimensions to ``path``, as
    :func:`write_las` does, chunk by chunk: ``saliency_chunks(start, stop)`` gives the Saliency
    of points [start, stop), ``extra(xyz)`` (optional) more :class:`~lidar_sig.io.fields.Fields`
    of the chunk's points from their (N, 3) coordinates (a change map's per-point change).
    Memory is bounded by the chunk, whatever the file's size."""
    notes = []
    ranges = {}
    with laspy.open(source) as reader, ThreadPoolExecutor(1, thread_name_prefix="lidar-sig laz") as compressing:
        crs, units = las_units(reader.header, path=source)
        header, evlrs = reader.header, reader.header.evlrs
        writer_cm = writer = appended = pending = None
        start = 0
        try:
            for chunk in reader.chunk_iterator(chunk_points):
                stop = start + len(chunk)
                xyz = None
                if extra is not None or appended is None:  # the coordinates, where something reads them
                    xyz = las_xyz(chunk)
                fields = saliency_fields(saliency_chunks(start, stop), scale_kind, scale_values)
                if extra is not None:
                    fields.update(extra(xyz))
                if appended is not None:  # the source's records as they are, the fields after them
                    points = appended(chunk, fields)
                    columns = {names[name]: values for name, values in fields.items()}
                else:
                    part = laspy.LasData(header=copy.deepcopy(header), points=chunk)
                    las, notes = with_fields(PointCloud(xyz, source=part, path=str(source), crs=crs, units=units),
                                             fields)
                    points = las.points
                    if writer is None:
                        writer_cm = _las_writer(path, las.header, overwrite)
                        writer = writer_cm.__enter__()
                        (appended, names), out_header = _appender(chunk, las, fields), las.header
                    columns = {}
                # compressed in a thread while the next chunk is read and filled (lazrs releases
                # the GIL): one chunk at a time in flight, in order
                if pending is not None:
                    pending.result()
                pending = compressing.submit(writer.write_points, points)
                extend_ranges(ranges, out_header, points, columns)
                start = stop
                stop_if_interrupted()  # a long streamed write ends soon after Ctrl-C or SIGTERM
            if pending is not None:
                pending.result()
            if writer is None:
                raise LidarSigError("the file holds no points; give a file with points", path=source)
            if evlrs:
                writer.write_evlrs(without_copc(evlrs))
            set_extra_bytes_ranges(writer.header, None, ranges)
        except BaseException as exc:
            if pending is not None:  # the writer is closed only once its last chunk is done
                pending.exception()
            if writer_cm is not None:
                writer_cm.__exit__(type(exc), exc, exc.__traceback__)
            raise
        writer_cm.__exit__(None, None, None)
    for text in notes:
        warnings.warn(text, LidarSigWarning, stacklevel=2)


def _appender(chunk, las, fields):
    """``(chunk, fields) -> point record`` of a later chunk written as the first one, ``las``
    (its LasData with the ``fields``), was, when that kept the source's point records byte for
    byte and put the fields after them (a LAS 1.4 source without an earlier run's dimensions):
    one copy of the records instead of laspy's field by field, and the fields' names in the
    records (field -> dimension name); (None, None) otherwise."""
    src, out = chunk.array.dtype, las.points.array.dtype
    added = [n for n in out.names if n not in src.names]
    kept = all(n in out.names and out.fields[n][:2] == src.fields[n][:2] for n in src.names)
    if not kept or len(added) != len(fields) or out.itemsize != src.itemsize + sum(
            out.fields[n][0].itemsize for n in added):
        return None, None
    names = dict(zip(fields, added))  # add_fields appends them in the fields' order
    point_format = las.header.point_format

    def appended(part, values):
        if values.keys() != names.keys():  # every byte of a record is written: the same fields each chunk
            raise RuntimeError(f"a chunk's fields {sorted(values)} differ from the first chunk's {sorted(names)}")
        array = np.empty(len(part), out)
        source = np.ascontiguousarray(part.array).view(np.uint8).reshape(len(part), -1)
        array.view(np.uint8).reshape(len(part), -1)[:, :src.itemsize] = source
        for name, v in values.items():
            array[names[name]] = v
        return laspy.PackedPointRecord(array, point_format)
    return appended, names


@contextlib.contextmanager
def _las_writer(path, header, overwrite):
    compress = str(path).lower().endswith(".laz")
    with atomic_output(path, overwrite=overwrite) as tmp, open(tmp, "wb") as raw:
        fh = _KeepsWriteErrors(raw)
        try:
            with laspy.LasWriter(fh, header, do_compress=compress, closefd=False) as writer:
                yield writer
        except Exception:
            if fh.error is not None:  # lazrs reports a failed write as an error of its own
                raise fh.error from None
            raise


class _KeepsWriteErrors:
    """A file that keeps the OSError of a failed write (a full disk, a quota), so that it is
    reported as such when the LAZ compressor turns it into an error of its own."""

    def __init__(self, fh):
        self._fh = fh
        self.error = None

    def write(self, data):
        try:
            return self._fh.write(data)
        except OSError as exc:
            self.error = exc
            raise

    def __getattr__(self, name):
        return getattr(self._fh, name)
