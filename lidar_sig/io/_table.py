"""The per-point table the PLY, PCD and text writers share: every attribute of the cloud, the
label, then the saliency outputs.

Names follow laspy's: a LAS source gives its dimensions (intensity, return_number, gps_time,
red, green, blue, nir, ... and any extra dimension); colours are ``red``, ``green``, ``blue``,
normals ``nx``, ``ny``, ``nz``; another (N, k) attribute ``name_0`` ... ``name_{k-1}``.
"""
from __future__ import annotations

import numpy as np

from .fields import output_names, replaced

CC_PREFIX = "scalar_"  # CloudCompare's mark of a scalar field in PLY and text files
_CC_OWN = ("red", "green", "blue", "nx", "ny", "nz")  # colours and normals it reads by name


def cloudcompare_name(name):
    """The PLY property or text column name under which CloudCompare loads ``name`` as a scalar
    field named after it: colours and normals keep theirs, every other name gets ``scalar_``
    (without it CloudCompare skips PLY properties and guesses text columns from their values:
    three columns in [0, 1] become normals, ``intensity`` grey colours, ``label`` text labels)."""
    return name if name in _CC_OWN else CC_PREFIX + name


def plain_name(name):
    """``name`` without CloudCompare's ``scalar_`` prefix."""
    return name[len(CC_PREFIX):] if name.startswith(CC_PREFIX) else name


def point_table(cloud, fields, *, keep_earlier=True):
    """``(columns, outputs, note)`` for writing ``cloud`` with the per-point ``fields``.

    ``columns`` maps names to (N,) arrays: the cloud's attributes, ``label`` (if labelled), then
    the fields; ``outputs`` are the names in it lidar_sig wrote: an earlier run's that stay, then
    the fields' (``lidar_sig_<name>`` when the cloud has an attribute of its own under one of our
    names, ``note`` then says so). Attributes an earlier run of the same kind wrote are left out:
    the new fields replace them (:func:`lidar_sig.io.fields.replaced`); without ``keep_earlier``
    every output of an earlier run is left out.
    """
    columns = {}
    gone = replaced(cloud.previous_outputs, fields) if keep_earlier else cloud.previous_outputs
    for name, values in _attributes(cloud).items():
        if name in gone:
            continue
        name = "_".join(str(name).replace(",", " ").split())  # one word: PLY, PCD and CSV headers
        values = np.asarray(values)
        if values.dtype == bool:
            values = values.astype(np.uint8)
        if values.ndim == 1:
            columns[name] = values
        elif name == "colors" and values.shape[1] == 3:
            if values.dtype.kind == "f":  # Open3D's float colours in [0, 1]
                values = np.rint(np.clip(values, 0.0, 1.0) * 255).astype(np.uint8)
            columns.update(red=values[:, 0], green=values[:, 1], blue=values[:, 2])
        elif name == "normals" and values.shape[1] == 3:
            columns.update(nx=values[:, 0], ny=values[:, 1], nz=values[:, 2])
        else:
            columns.update({f"{name}_{k}": values[:, k] for k in range(values.shape[1])})
    if cloud.labels is not None:
        columns["label"] = np.asarray(cloud.labels).astype(np.int32)  # class codes; PLY has no int64
    names, note = output_names(fields, columns, path=cloud.path)
    for name, values in fields.items():
        columns[names[name]] = np.asarray(values)
    kept = [name for name in cloud.previous_outputs if name in columns]
    return columns, kept + list(names.values()), note


def _attributes(cloud):
    """The cloud's per-point attributes; for a LAS source its dimensions but X, Y, Z and the
    classification (which is the label)."""
    import laspy

    if isinstance(cloud.source, laspy.LasData):
        las = cloud.source
        return {name: np.asarray(las[name]) for name in las.point_format.dimension_names
                if name not in ("X", "Y", "Z", "classification")}
    return dict(cloud.attributes)

