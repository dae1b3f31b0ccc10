"""Plain-text point clouds: one point per line, whitespace- or comma-separated columns.

Column layout by count unless given: 3 = X Y Z, 4 = X Y Z label, 7 = the ISPRS Vaihingen 3D
layout X Y Z Intensity return_number number_of_returns label. ``columns`` names each column
(``x``, ``y``, ``z``, ``label``; anything else is kept as an attribute, ``-`` skips it). A
commented header line naming x, y and z (as this module writes) sets the layout.

Written files are comma-separated with CloudCompare's header line
``//X,Y,Z,scalar_intensity,...,red,green,blue,...,scalar_Cl,...``: every attribute of the
cloud, the label and the outputs, named so that CloudCompare loads each as a named scalar field
(colours and normals as such); read back here without the ``scalar_`` prefix. A second comment
line lists the outputs lidar_sig wrote.
"""
from __future__ import annotations

import warnings

import numpy as np

from ..method.cloud import PointCloud
from ..base.errors import LidarSigError, LidarSigWarning, a_kind, arg, counted
from .atomic import atomic_output
from .fields import marker, parse_marker
from .formats import TEXT_EXTENSIONS  # noqa: F401 (a name of this module too)
from ._table import cloudcompare_name, plain_name, point_table

LAYOUTS = {
    3: ("x", "y", "z"),
    4: ("x", "y", "z", "label"),
    7: ("x", "y", "z", "intensity", "return_number", "number_of_returns", "label"),
}


def parse_columns(text):
    """``"x,y,z,-,label"`` (or a list of the names) -> a tuple of column names; must hold x, y
    and z, and name every column (an empty item would shift the columns after it)."""
    if isinstance(text, (list, tuple)) and all(isinstance(c, str) for c in text):
        text = ",".join(text)
    if not isinstance(text, str):
        raise LidarSigError(f"columns must be a text such as 'x,y,z,-,label' or a list of column names, got "
                            f"{a_kind(text)}")
    items = [c.strip() for c in str(text).split(",")]
    if "" in items:
        raise LidarSigError(f"columns has an empty item in {text!r}; name every column, - for one to skip "
                            "(e.g. x,y,z,-,label)")
    cols = tuple(_name(c) for c in items)
    if not {"x", "y", "z"} <= set(cols) or len(set(c for c in cols if c != "-")) != len([c for c in cols if c != "-"]):
        raise LidarSigError(f"columns must name x, y and z once each, got {text!r} (e.g. x,y,z,-,label)")
    return cols


def read_text(path, columns=None):
    """Read a text point cloud; lines starting with ``#`` or ``//`` are comments, a first line
    that is not numeric is a header, a ``.pts`` point-count line is skipped. ``columns`` names
    the columns (``"x,y,z,-,label"`` or a list of names: :func:`parse_columns`)."""
    if columns is not None:
        columns = parse_columns(columns)
    try:
        with open(path, encoding="utf-8") as fh:
            raw = [(number, ln) for number, ln in enumerate(fh, 1) if ln.strip()]
    except UnicodeDecodeError:
        raise LidarSigError("is not a text point cloud (binary content)", path=path) from None
    comments = [ln.strip().lstrip("#/ ") for _, ln in raw if ln.lstrip().startswith(("#", "//"))]
    rows = [(number, ln) for number, ln in raw if not ln.lstrip().startswith(("#", "//"))]
    if columns is None:  # a commented header naming x, y and z (as this module writes) sets the layout
        named = [words for words in (c.replace(",", " ").split() for c in comments)
                 if {"x", "y", "z"} <= {w.lower() for w in words}]
        columns = tuple(_name(w) for w in named[0]) if named else None
    if rows and not _numeric(rows[0][1]):
        rows = rows[1:]  # header line
    if rows and len(rows[0][1].replace(",", " ").split()) == 1:
        rows = rows[1:]  # .pts point count
    if not rows:
        raise LidarSigError("the file holds no points; give a file with points", path=path)
    lines = [ln for _, ln in rows]
    n_cols = len(lines[0].replace(",", " ").split())
    layout = tuple(columns) if columns else LAYOUTS.get(n_cols)
    if layout is None:
        raise LidarSigError(f"has {counted(n_cols, 'column')}; name them with {arg('columns')} (e.g. x,y,z,-,label)",
                            path=path)
    if len(layout) != n_cols:
        raise LidarSigError(f"has {counted(n_cols, 'column')} but {arg('columns')} names {len(layout)}", path=path)
    delimiter = "," if "," in lines[0] else None
    try:
        data = np.loadtxt(lines, delimiter=delimiter, ndmin=2)
    except ValueError:
        raise LidarSigError(_unparsed(rows, n_cols, delimiter), path=path) from None
    col = {name: data[:, k] for k, name in enumerate(layout) if name != "-"}
    labels = None
    if "label" in col:
        lab = col.pop("label")
        if not (np.all(np.isfinite(lab)) and np.all(lab == np.round(lab))):
            raise LidarSigError(f"the label column holds non-integer values; check {arg('columns')}", path=path)
        labels = lab.astype(np.int64)
    xyz = np.column_stack([col.pop("x"), col.pop("y"), col.pop("z")])
    return PointCloud(xyz, labels, source=None, path=str(path), attributes=col,
                      previous_outputs=parse_marker(comments))


def write_text(path, cloud, fields, *, overwrite=False):
    """Write X, Y, Z, every attribute of the cloud, the label (if any) and the per-point
    ``fields`` {name: array} as comma-separated columns under CloudCompare's header line.

    Coordinates and float64 values keep 17 significant digits and float32 values 9, so reading
    the file back gives the same numbers; undefined values are ``nan``.
    """
    columns, outputs, note = point_table(cloud, fields)
    names = ["X", "Y", "Z"] + [cloudcompare_name(n) for n in columns]
    cols = [cloud.xyz[:, 0], cloud.xyz[:, 1], cloud.xyz[:, 2]]
    fmt = ["%.17g"] * 3
    for values in columns.values():
        cols.append(values)
        fmt.append("%d" if values.dtype.kind in "iub" else "%.9g" if values.dtype.itemsize <= 4 else "%.17g")
    header = "//" + ",".join(names) + "\n// " + marker(outputs)
    with atomic_output(path, overwrite=overwrite) as tmp:
        np.savetxt(tmp, np.column_stack(cols), fmt=fmt, delimiter=",", header=header, comments="")
    if note:
        warnings.warn(note, LidarSigWarning, stacklevel=4)  # the caller of Result.write


def _unparsed(rows, n_cols, delimiter):
    """Why numbered ``rows`` (line number, text) are not a table of ``n_cols`` numbers: the first
    line with another number of columns, or the first value that is not a number."""
    first = rows[0][0]
    for number, line in rows:
        values = [v.strip() for v in line.split(delimiter)] if delimiter else line.split()
        if len(values) != n_cols:
            return (f"line {number} has {counted(len(values), 'column')}, line {first} has {n_cols}; give "
                    "every line the same columns")
        for value in values:
            if not _numeric(value):
                return f"line {number} holds {value[:40]!r}, not a number; every value must be a number"
    return f"cannot read its lines as {counted(n_cols, 'column')} of numbers; check the file"


def _name(word):
    # x, y, z and label in any case, without CloudCompare's scalar_ prefix; others as written
    word = plain_name(word)
    return word.lower() if word.lower() in ("x", "y", "z", "label") else word


def _numeric(line):
    try:
        [float(v) for v in line.replace(",", " ").split()]
    except ValueError:
        return False
    return True
