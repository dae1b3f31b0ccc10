"""The saliency's extra dimensions (docs/method.md, "LAS/LAZ output"): their LAS types and descriptions, how a later run
recognises the ones an earlier run wrote, adding them to a LasData, and the min and max each
extra-bytes record declares.
"""
from __future__ import annotations

import laspy
import numpy as np

from ..fields import CHANGE_DESCRIPTIONS, OPTIMAL_DESCRIPTIONS, PREFIX, SALIENCY_DESCRIPTIONS, output_names, replaced

# name -> (LAS extra-bytes type, description of at most 32 bytes): the saliency's dimensions.
# 2-byte integers because QGIS drops 1-byte extra dimensions. The descriptions also mark a
# dimension as ours (OptimalScale's says what its value is, per kind of scales).
SALIENCY_DIMS = {**{name: ("u2" if name == "GeomClass" else "f4", text) for name, text in SALIENCY_DESCRIPTIONS.items()},
                 "OptimalScale": ("u2", "")}
# Undefined saliency: NaN in the float dimensions, 0 in the integer ones (GeomClass "none",
# OptimalScale "no scale"); declared as the no-data value of each extra dimension.
NO_DATA = {"f": np.nan, "u": 0}


def is_ours(name, description):
    """True for a dimension a lidar_sig run wrote: one of our names (plain or prefixed) with
    the description we give it."""
    base = name[len(PREFIX):] if name.startswith(PREFIX) else name
    if base == "OptimalScale":
        return description in OPTIMAL_DESCRIPTIONS.values()
    if base in CHANGE_DESCRIPTIONS:  # the per-point change: its description up to the metric's name
        return description.startswith(CHANGE_DESCRIPTIONS[base].split("{")[0])
    return base in SALIENCY_DIMS and description == SALIENCY_DIMS[base][1]


def lidar_sig_dims(las):
    """Names of the extra dimensions of ``las`` that an earlier lidar_sig run wrote."""
    return tuple(d.name for d in las.point_format.extra_dimensions if is_ours(d.name, d.description))


def add_fields(las, fields, *, path=None):
    """Set the per-point ``fields`` (:class:`lidar_sig.io.fields.Fields`: each in its values'
    type, with its description) as extra dimensions of ``las`` (those of an earlier run of the
    same kind are replaced, :func:`lidar_sig.io.fields.replaced`); returns the notes on what the caller should know (outputs renamed beside a user's
    own)."""
    notes = []
    previous = replaced(lidar_sig_dims(las), fields)
    if previous:  # a re-run replaces instead of duplicating
        las.remove_extra_dims(previous)
    names, note = output_names(fields, las.point_format.dimension_names, previous, path=path)
    if note:
        notes.append(note)
    params = []
    for name, values in fields.items():
        kind = np.asarray(values).dtype
        params.append(laspy.ExtraBytesParams(name=names[name], type=kind, description=fields.descriptions[name],
                                             no_data=[NO_DATA[kind.kind]]))
    las.add_extra_dims(params)
    for name, values in fields.items():
        las[names[name]] = values
    return notes


def extend_ranges(ranges, header, points, columns=None):
    """Widen ``ranges`` ({(name, element): (min, max)}) by each extra dimension's values in
    ``points`` that are not its no-data value (NaN never counts), as
    :func:`set_extra_bytes_ranges` keeps them: over the chunks of a file written in parts.
    ``columns`` ({dimension name: values}, optional) are the values of some dimensions, read
    instead of the points' (cast to the dimension's type, as the records hold them): a column
    of packed records is read with a stride of a record, tens of times slower."""
    columns = columns or {}
    for vlr in header.vlrs.get("ExtraBytesVlr"):
        for record in vlr.extra_bytes_structs:
            name = record.format_name()
            if name not in points.array.dtype.names:
                continue
            kind = points.array.dtype[name].base  # a column as the records keep it (no copy when it is)
            raw = np.asarray(columns[name] if name in columns else points.array[name], kind).reshape(len(points), -1)
            no_data = record.no_data
            for i in range(raw.shape[1] if len(raw) else 0):
                column = raw[:, i]
                if no_data is not None and not np.isnan(no_data[i]):
                    column = column[column != no_data[i]]
                if not len(column):
                    continue
                low, high = np.fmin.reduce(column), np.fmax.reduce(column)  # NaN never counts
                if column.dtype.kind == "f" and np.isnan(low):
                    continue
                lo, hi = ranges.get((name, i), (low, high))
                ranges[(name, i)] = (min(lo, low), max(hi, high))


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
        extend_ranges(ranges, header, points)
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
