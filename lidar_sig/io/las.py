"""LAS/LAZ through laspy: read into a PointCloud, write per-point saliency as extra dimensions.

Written files are LAS 1.4 (the version whose specification defines extra dimensions). A LAS 1.4
input keeps every original point record byte, VLR/EVLR and the CRS; an older input (1.0-1.3) is
converted to the matching 1.4 point format with every dimension's values kept (see
``upgrade_to_14``). A COPC input is written as plain LAZ. The saliency dimensions of SPEC 8 are
added; those of an earlier run are replaced, a user's own dimension of the same name never is.
"""
from __future__ import annotations

import contextlib
import copy
import datetime
import warnings

import laspy
import numpy as np

from ..cloud import PointCloud
from ..crs import las_crs, las_units
from ..errors import LidarSigError, LidarSigWarning
from .atomic import atomic_output, stop_if_interrupted

LAS_EXTENSIONS = (".las", ".laz")

# name -> (LAS extra-bytes type, description of at most 32 bytes). 2-byte integers because
# QGIS drops 1-byte extra dimensions. The descriptions also mark a dimension as ours.
SALIENCY_DIMS = {
    "Cl": ("f4", "line-type saliency Cl [0,1]"),
    "Cs": ("f4", "surface-type saliency Cs [0,1]"),
    "Cp": ("f4", "point-type saliency Cp [0,1]"),
    "Egeom": ("f4", "geometric entropy [nats]"),
    "GeomClass": ("u2", "1 line 2 surface 3 point 0 none"),
    "OptimalScale": ("u2", ""),  # description set per run: k, or radius index
}
_OPTIMAL_DESC = {"knn": "k of minimum-entropy scale", "radius": "index of min-entropy radius"}
# Our names when the input already has a dimension of the same name that is not ours.
PREFIX = "lidar_sig_"
# Undefined saliency: NaN in the float dimensions, 0 in the integer ones (GeomClass "none",
# OptimalScale "no scale"); declared as the no-data value of each extra dimension.
NO_DATA = {"f": np.nan, "u": 0}

# LAS 1.0-1.3 point format -> the LAS 1.4 format with the same dimensions (and more).
FORMAT_14 = {0: 6, 1: 6, 2: 7, 3: 7, 4: 9, 5: 10}
SCAN_ANGLE_UNIT = 0.006  # degrees per step of the LAS 1.4 scan_angle dimension


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
    records = _records_in_file(path, las.header)
    if records is not None and records > las.header.point_count:
        warnings.warn(f"{path}: the header counts {las.header.point_count:,} points but the file holds "
                      f"{records:,} point records; only the header's {las.header.point_count:,} are read (fix the "
                      "header's point count to use them all)", LidarSigWarning, stacklevel=3)
    xyz = np.column_stack([np.asarray(las.x), np.asarray(las.y), np.asarray(las.z)])
    labels = np.asarray(las.classification, dtype=np.int64)
    if not labels.any():
        labels = None  # class 0 "created, never classified" everywhere: an unlabeled cloud
    crs, units = las_units(las.header, path=path)
    return PointCloud(xyz, labels, source=las, path=str(path), previous_outputs=lidar_sig_dims(las),
                      crs=crs, units=units)


def _records_in_file(path, header):
    """Point records an uncompressed LAS file holds, from its size (None for LAZ, where only the
    compressed chunks know): a header may count fewer than there are."""
    import os

    if header.are_points_compressed:
        return None
    end = os.path.getsize(path)
    if header.number_of_evlrs and header.start_of_first_evlr:
        end = min(end, header.start_of_first_evlr)
    waveforms = getattr(header, "start_of_waveform_data_packet_record", 0)
    if waveforms and waveforms > header.offset_to_point_data:
        end = min(end, waveforms)
    return max(0, end - header.offset_to_point_data) // header.point_format.size


def _reason(exc):
    text = str(exc).strip().splitlines()
    return (text[0] if text else type(exc).__name__)[:160]


def is_ours(name, description):
    """True for a dimension a lidar_sig run wrote: one of our names (plain or prefixed) with
    the description we give it."""
    base = name[len(PREFIX):] if name.startswith(PREFIX) else name
    if base == "OptimalScale":
        return description in _OPTIMAL_DESC.values()
    return base in SALIENCY_DIMS and description == SALIENCY_DIMS[base][1]


def lidar_sig_dims(las):
    """Names of the extra dimensions of ``las`` that an earlier lidar_sig run wrote."""
    return tuple(d.name for d in las.point_format.extra_dimensions if is_ours(d.name, d.description))


def output_names(fields, existing, previous=(), *, path=None):
    """Names to write the per-point ``fields`` under, and a note (or None).

    ``existing`` are the attribute names the output already holds, ``previous`` those of them an
    earlier lidar_sig run wrote (the caller drops them: they are replaced). When the input has
    an attribute of its own under one of our names, every field is written as ``lidar_sig_<name>``
    so that nothing of the user's is overwritten.
    """
    own = set(existing) - set(previous)
    clash = [n for n in fields if n in own]
    if not clash:
        return {n: n for n in fields}, None
    names = {n: PREFIX + n for n in fields}
    taken = [v for v in names.values() if v in own]
    if taken:
        raise LidarSigError(f"has its own attributes {', '.join(clash + taken)}, named like lidar_sig's "
                            "outputs; rename them before running", path=path or "input")
    note = (f"the input has its own {', '.join(clash)} (not written by lidar_sig), kept as they are; "
            f"the saliency is written as {', '.join(names.values())}")
    return names, note


def to_lasdata(cloud):
    """A fresh LAS 1.4 LasData of the cloud, and notes on what changed from the source.

    The source's LasData is copied (LAS 1.0-1.3 upgraded to 1.4, COPC records dropped); a cloud
    without one is made by :func:`_new_lasdata`. The generating software and the
    creation date say lidar_sig and today, as the header of any file a program writes.
    """
    from .. import __version__

    src = cloud.source
    notes = []
    if isinstance(src, laspy.LasData):
        las = laspy.LasData(header=copy.deepcopy(src.header), points=src.points.copy())
        if _drop_copc(las.header):
            notes.append("COPC input written as plain LAZ 1.4 (same points and dimensions; "
                         "the COPC octree index is dropped)")
        if las.header.version.minor < 4:
            las, more = upgrade_to_14(las)
            notes += more
    else:
        las = _new_lasdata(cloud)
    las.header.generating_software = f"lidar_sig {__version__}"
    las.header.creation_date = datetime.date.today()
    return las, notes


def _new_lasdata(cloud):
    """LAS 1.4 LasData of a cloud read from another format: millimetre scales, point format 6,
    7 with colours, 8 with colours and nir; attributes named like a dimension of the format
    (intensity, return_number, gps_time, ...) fill it when their values fit its type, every
    other one (or one that does not fit, as ``<name>_value``) becomes an extra dimension."""
    from .table import point_table

    columns, _, _ = point_table(cloud, {})
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
    """LAS offsets and scales for coordinates ``xyz``: offsets at the floor of the minimum,
    millimetre scales unless the extent needs coarser ones to fit LAS's 32-bit integers (then
    the next power of ten)."""
    lo, hi = xyz.min(axis=0), xyz.max(axis=0)
    offsets = np.floor(lo)
    span = np.maximum(hi - offsets, 1e-12)
    scales = np.maximum(1e-3, 10.0 ** np.ceil(np.log10(span / (2**31 - 2))))
    return offsets, scales


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


def upgrade_to_14(las):
    """LAS 1.0-1.3 ``las`` as LAS 1.4 with the matching point format (0/1 -> 6, 2/3 -> 7, 4 -> 9,
    5 -> 10), every dimension's values kept, and notes on the change.

    laspy.convert copies dimensions by name and keeps the header's other fields and the VLRs.
    The one dimension LAS 1.4 renames, scan_angle_rank (whole degrees), becomes scan_angle in
    steps of 0.006 degrees (rounded; rounding back to degrees gives the rank). Classification
    codes and the synthetic, key-point and withheld flags keep their values. The global encoding
    keeps its GPS-time and waveform bits and gets the WKT bit, which LAS 1.4 requires with formats
    6-10 (PDAL, and so QGIS, refuse such a file without it and read its CRS from WKT only): a CRS
    given as GeoTIFF keys is therefore also written as WKT; the keys stay.
    """
    old, version = las.point_format.id, str(las.header.version)
    new = laspy.convert(las, point_format_id=FORMAT_14[old], file_version="1.4")
    if "scan_angle_rank" in las.point_format.dimension_names:
        degrees = np.asarray(las.scan_angle_rank, dtype=np.float64)
        new.scan_angle = np.round(degrees / SCAN_ANGLE_UNIT).astype(np.int16)
    new.header.global_encoding.wkt = True
    notes = [f"LAS {version} input written as LAS 1.4 (point format {old} -> {FORMAT_14[old]}), the "
             "version that defines extra dimensions; every original dimension keeps its values"]
    vlrs = new.header.vlrs
    if vlrs.get("GeoKeyDirectoryVlr") and not vlrs.get("WktCoordinateSystemVlr"):
        wkt = _wkt_from_geotiff(las.header)
        if wkt:
            vlrs.append(laspy.vlrs.known.WktCoordinateSystemVlr(wkt))
        else:
            notes.append("the CRS in the GeoTIFF keys has no EPSG code that could be written as "
                         "WKT; the keys are kept, but PDAL and QGIS will show no CRS")
    return new, notes


def _wkt_from_geotiff(header):
    """OGC WKT 1 (as GDAL and PDAL write it) of the CRS in the GeoTIFF keys, or None
    (compound when a vertical EPSG code is given; see :func:`lidar_sig.crs.las_crs`)."""
    crs = las_crs(header)
    return crs.to_wkt(version="WKT1_GDAL") if crs is not None else None


def _drop_copc(header):
    """Remove the COPC info VLR and hierarchy EVLR (a plain LAZ writer cannot keep the octree
    they index); True if there were any."""
    found = False
    for records in (header.vlrs, header.evlrs):
        if records is None:
            continue
        copc = [v for v in records if v.user_id == "copc"]
        for v in copc:
            records.remove(v)
        found = found or bool(copc)
    return found


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
    """Write the cloud with saliency extra dimensions (SPEC 8) to ``path`` (.las or .laz), LAS 1.4.

    Cl, Cs, Cp, Egeom as float32 (NaN where undefined), GeomClass as uint16 (0 where undefined);
    with an Optimal-scale result also OptimalScale (uint16): the chosen k for k-nearest scales,
    the 1-based radius index for spherical ones, 0 where undefined. NaN and 0 are declared as the
    dimensions' no-data values; their min and max are those of the defined values. What the
    caller should know (an upgraded version, a dropped COPC index, renamed outputs) is issued as
    a :class:`LidarSigWarning` once the file is written.
    """
    check_las_output(cloud, path)
    las, notes = with_saliency(cloud, saliency, scale_kind, scale_values)
    with _las_writer(path, las.header, overwrite) as writer:
        writer.write_points(las.points)
        if las.evlrs:
            writer.write_evlrs(las.evlrs)
        # the writer rewrites its header, VLRs included, when it closes
        set_extra_bytes_ranges(writer.header, las.points)
    for text in notes:
        warnings.warn(text, LidarSigWarning, stacklevel=4)  # the caller of Result.write


def with_saliency(cloud, saliency, scale_kind=None, scale_values=None):
    """The LAS 1.4 LasData written for ``cloud`` (see :func:`to_lasdata`) with the saliency
    extra dimensions set, and the notes on what changed."""
    las, notes = to_lasdata(cloud)
    previous = lidar_sig_dims(las)
    if previous:  # a re-run replaces instead of duplicating
        las.remove_extra_dims(previous)
    fields = saliency_fields(saliency, scale_kind, scale_values)
    names, note = output_names(fields, las.point_format.dimension_names, previous, path=cloud.path)
    if note:
        notes.append(note)
    params = []
    for name, values in fields.items():
        kind, desc = SALIENCY_DIMS[name]
        if name == "OptimalScale":
            desc = _OPTIMAL_DESC[scale_kind]
        params.append(laspy.ExtraBytesParams(name=names[name], type=np.dtype(kind), description=desc,
                                             no_data=[NO_DATA[np.dtype(kind).kind]]))
    las.add_extra_dims(params)
    for name, values in fields.items():
        las[names[name]] = values
    return las, notes


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


def write_las_chunks(path, source, saliency_chunks, *, scale_kind=None, scale_values=None, overwrite=False,
                     chunk_points=500_000):
    """Write the LAS/LAZ file ``source`` with saliency extra dimensions to ``path``, as
    :func:`write_las` does, chunk by chunk: ``saliency_chunks(start, stop)`` gives the Saliency
    of points [start, stop). Memory is bounded by the chunk, whatever the file's size."""
    notes = []
    ranges = {}
    with laspy.open(source) as reader:
        crs, units = las_units(reader.header, path=source)
        header, evlrs = reader.header, reader.header.evlrs
        writer_cm = writer = None
        start = 0
        try:
            for chunk in reader.chunk_iterator(chunk_points):
                stop = start + len(chunk)
                part = laspy.LasData(header=copy.deepcopy(header), points=chunk)
                cloud = PointCloud(np.column_stack([np.asarray(chunk.x), np.asarray(chunk.y), np.asarray(chunk.z)]),
                                   source=part, path=str(source), crs=crs, units=units)
                las, notes = with_saliency(cloud, saliency_chunks(start, stop), scale_kind, scale_values)
                if writer is None:
                    writer_cm = _las_writer(path, las.header, overwrite)
                    writer = writer_cm.__enter__()
                writer.write_points(las.points)
                _extend_ranges(ranges, las.header, las.points)
                start = stop
                stop_if_interrupted()  # a long streamed write ends soon after Ctrl-C or SIGTERM
            if writer is None:
                raise LidarSigError("the file holds no points; give a file with points", path=source)
            if evlrs:
                writer.write_evlrs([v for v in evlrs if v.user_id != "copc"])
            set_extra_bytes_ranges(writer.header, None, ranges)
        except BaseException as exc:
            if writer_cm is not None:
                writer_cm.__exit__(type(exc), exc, exc.__traceback__)
            raise
        writer_cm.__exit__(None, None, None)
    for text in notes:
        warnings.warn(text, LidarSigWarning, stacklevel=2)


def _extend_ranges(ranges, header, points):
    # each extra dimension's (min, max) over the chunks so far, as set_extra_bytes_ranges keeps them
    for vlr in header.vlrs.get("ExtraBytesVlr"):
        for record in vlr.extra_bytes_structs:
            name = record.format_name()
            if name not in points.array.dtype.names:
                continue
            raw = np.asarray(points.array[name]).reshape(len(points), -1)
            keep = ~np.isnan(raw) if raw.dtype.kind == "f" else np.ones(raw.shape, bool)
            no_data = record.no_data
            if no_data is not None:
                for i in range(raw.shape[1]):
                    if not np.isnan(no_data[i]):
                        keep[:, i] &= raw[:, i] != no_data[i]
            for i in range(raw.shape[1]):
                values = raw[keep[:, i], i]
                if len(values):
                    lo, hi = ranges.get((name, i), (values.min(), values.max()))
                    ranges[(name, i)] = (min(lo, values.min()), max(hi, values.max()))


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


def set_extra_bytes_ranges(header, points, ranges=None):
    """Store in each extra-bytes record that flags a min or a max the true min and max of the
    dimension's values that are not its no-data value (NaN never counts); a dimension without
    such values gets none. ``ranges`` ({(name, element): (min, max)}, from a file written in
    chunks) replaces ``points``.

    laspy (2.7) rebuilds every record when dimensions are added, flags both and stores the first
    point's value: a user's dimensions get their true range too.
    """
    if ranges is None:
        ranges = {}
        _extend_ranges(ranges, header, points)
    for vlr in header.vlrs.get("ExtraBytesVlr"):
        for record in vlr.extra_bytes_structs:
            if record.data_type == 0 or not (record.min_is_relevant() or record.max_is_relevant()):
                continue
            low, high = record._raw_min(), record._raw_max()  # writable views, None where not flagged
            for i in range(record.num_elements()):
                if (record.format_name(), i) not in ranges:
                    record.options &= ~(record.MIN_BIT_MASK | record.MAX_BIT_MASK)
                    break
                lo_i, hi_i = ranges[(record.format_name(), i)]
                if low is not None:
                    low[i] = lo_i
                if high is not None:
                    high[i] = hi_i
