"""HDF5 survey catalogues: one row per tile (path, SHA-256, CRS, footprint, counts, features) and
the catalogue's method, class table, frame and metric spreads; written atomically, read back
checked. docs/catalog.md lists the layout.

A tile's signature counts are stored sparse (the flat indices of its non-zero pixels and their
counts, gzip-compressed): a dense count raster of 20 classes x 512^2 pixels is 40 MiB a tile,
its non-zero pixels about 30 KiB. Hulls are stored the same way (one list of vertices, offsets
per tile).
"""
from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from ..classes import recorded_table
from ..errors import LidarSigError, as_path, special_file
from ..metrics import FV_GRID, MAX_COLOR_BINS, METRIC_KEYS, SEMANTIC_KEYS, fv_mixture
from ..signature import EGEOM_BINS, METHOD_KEYS, Frame
from .h5 import described_dataset, hdf5_output

FORMAT = "lidar_sig survey catalogue"
FORMAT_VERSION = 1

#: Per-tile columns: name -> (dtype, description, units). Text columns have dtype "str".
COLUMNS = {
    "name": ("str", "file name of the tile", None),
    "path": ("str", "absolute path of the tile when it was computed", None),
    "sha256": ("str", "SHA-256 of the tile's file", None),
    "crs": ("i8", "index of the tile's CRS in /crs (its WKT; '' for none)", None),
    "factors": ("f8", "metres per coordinate unit of x, y, z", "m"),
    "n_points": ("i8", "points in the tile", "points"),
    "n_undefined": ("i8", "points with undefined saliency (left out of the signature)", "points"),
    "n_signature": ("i8", "points in the signature (the sum of its counts)", "points"),
    "bounds": ("f8", "plan-view bounds x0, y0, x1, y1 in the tile's CRS", "CRS units"),
    "area": ("f8", "area of the footprint (convex hull of the points in plan view)", "m2"),
    "density": ("f8", "points per square metre of footprint", "1/m2"),
    "class_totals": ("i8", "points of each class (class table order, 'other' last)", "points"),
    "egeom": ("i8", "histogram of Egeom over [0, ln 3] nats", "points"),
    "fv": ("f8", "Fisher vector of the signature's positions in the triangle (delta_FV)", None),
    "color": ("f8", "colour histogram of Sas, normalized (d_BD-Img, d_EMD-Img)", None),
    "meta": ("str", "JSON: resolved scales, units, capped and duplicate points, whether run in tiles", None),
}


def write_catalog(path, header, tiles, *, overwrite=False):
    """Write a catalogue: ``header`` (method dict, classes ClassTable, frame Frame, render,
    color_bins, spread dict) and ``tiles`` (dicts holding every field of COLUMNS, plus ``hull``
    (K, 2) and the sparse counts ``counts_at``, ``counts``)."""
    crs_list = sorted({t["crs"] or "" for t in tiles})
    classes = header["classes"]
    with hdf5_output(path, FORMAT, FORMAT_VERSION, overwrite=overwrite) as f:
        f.attrs["method"] = json.dumps(header["method"])
        f.attrs["classes"] = json.dumps({"name": classes.name, "names": list(classes.names),
                                         "codes": [list(map(int, c)) for c in classes.codes],
                                         "colors": [list(map(int, c)) for c in classes.colors],
                                         "noise": [int(c) for c in classes.noise]})
        f.attrs["frame_size"] = header["frame"].size
        f.attrs["frame_margin"] = header["frame"].margin
        f.attrs["render"] = header["render"]
        f.attrs["color_bins"] = int(header["color_bins"])
        f.attrs["spread"] = json.dumps(header["spread"])
        described_dataset(f, "crs", crs_list, "the tiles' CRSs as WKT ('' for none)")
        g = f.create_group("tiles")
        g.attrs["description"] = "one row per tile"
        g.attrs["n_tiles"] = len(tiles)
        for name, (dtype, description, units) in COLUMNS.items():
            if name == "crs":
                data = np.array([crs_list.index(t["crs"] or "") for t in tiles], np.int64)
            elif dtype == "str":
                data = [str(t[name]) for t in tiles]
            else:
                data = np.array([t[name] for t in tiles], dtype=dtype)
            described_dataset(g, name, data, description, units)
        hulls = [np.asarray(t["hull"], np.float64).reshape(-1, 2) for t in tiles]
        described_dataset(g, "hull_offsets", _offsets(hulls),
                          "tile i's hull is hull_xy[hull_offsets[i]:hull_offsets[i+1]]")
        described_dataset(g, "hull_xy", np.concatenate(hulls) if hulls else np.empty((0, 2)),
                          "convex hull of each tile's points in plan view, counter-clockwise", "CRS units")
        at = [np.asarray(t["counts_at"], np.int64) for t in tiles]
        described_dataset(g, "counts_offsets", _offsets(at),
                          "tile i's counts are rows counts_offsets[i]:counts_offsets[i+1]")
        described_dataset(g, "counts_index", np.concatenate(at) if at else np.empty(0, np.int64),
                          "flat index (class, row, col) of each non-zero pixel of the signature's count raster")
        values = [np.asarray(t["counts"], np.int64) for t in tiles]
        described_dataset(g, "counts_value", np.concatenate(values) if values else np.empty(0, np.int64),
                          "points of that class in that pixel", "points")


def _offsets(parts):
    return np.concatenate([[0], np.cumsum([len(p) for p in parts])]).astype(np.int64)


def _open(path):
    import h5py

    path = as_path(path, "a catalogue")
    if not path.is_file():
        raise LidarSigError("no such file; make a catalogue with `lidar-sig catalog TILES -o FILE.h5`"
                            if not path.exists() else
                            f"is {special_file(path) or 'a folder'}, not a regular file; give a catalogue", path=path)
    try:
        f = h5py.File(path, "r")
    except OSError as exc:
        raise LidarSigError(f"cannot be read as HDF5 ({str(exc).splitlines()[0][:120]}); check that the file "
                            "is complete", path=path) from None
    if f.attrs.get("format") != FORMAT:
        f.close()
        raise LidarSigError("is not a lidar_sig survey catalogue; make one with `lidar-sig catalog TILES -o FILE.h5`",
                            path=path)
    version = f.attrs.get("format_version", 0)
    if not isinstance(version, (int, np.integer)) or version > FORMAT_VERSION or version < 1:
        f.close()
        raise LidarSigError(f"catalogue format version {version!r} is not one this lidar_sig reads "
                            f"({FORMAT_VERSION}); upgrade lidar_sig", path=path)
    return f


def is_catalog(path):
    """Whether ``path`` is an HDF5 file marked as a survey catalogue."""
    import h5py

    if not Path(path).is_file():  # a FIFO would be waited on
        return False
    try:
        with h5py.File(path, "r") as f:
            return f.attrs.get("format") == FORMAT
    except (OSError, ValueError):
        return False


def read_catalog(path):
    """(header, columns) of a catalogue: the header as :func:`write_catalog` takes it (``crs``
    added: the list of WKT), the per-tile columns of COLUMNS as arrays (text as lists of str),
    ``hull`` a list of (K, 2) arrays and ``counts_offsets``; the counts themselves are read per
    tile (:func:`read_counts`). Damaged files give a LidarSigError naming what is wrong."""
    with _open(path) as f:
        try:
            return _read(f, path)
        except KeyError as exc:
            raise LidarSigError(f"catalogue lacks {exc}; it is damaged or incomplete", path=path) from None
        except (TypeError, ValueError, IndexError, OSError) as exc:
            if isinstance(exc, LidarSigError):
                raise
            raise LidarSigError(f"cannot be read as a catalogue ({str(exc).splitlines()[0][:120]}); it is damaged",
                                path=path) from None


def _text(ds):
    return [v.decode() if isinstance(v, bytes) else str(v) for v in ds[()]]


def _read(f, path):
    def damaged(what):
        return LidarSigError(f"{what}; the catalogue is damaged or was edited by hand", path=path)

    table = json.loads(f.attrs["classes"])
    classes = recorded_table(table["name"], table["names"], table["codes"], table["colors"], table.get("noise"))
    header = {"method": json.loads(f.attrs["method"]), "classes": classes,
              "frame": Frame(int(f.attrs["frame_size"]), int(f.attrs["frame_margin"])),
              "render": str(f.attrs["render"]), "color_bins": int(f.attrs["color_bins"]),
              "spread": json.loads(f.attrs["spread"]), "crs": _text(f["crs"])}
    g = f["tiles"]
    n = int(g.attrs["n_tiles"])
    columns = {}
    for name, (dtype, _, _) in COLUMNS.items():
        data = _text(g[name]) if dtype == "str" else g[name][()]
        if len(data) != n:
            raise damaged(f"its column {name} has {len(data)} rows, not {n}")
        columns[name] = data
    if n and (columns["crs"].min() < 0 or columns["crs"].max() >= len(header["crs"])):
        raise damaged("a tile's CRS index is out of range")
    if n and columns["class_totals"].shape[1] != len(classes):
        raise damaged(f"its class totals have {columns['class_totals'].shape[1]} classes, its table {len(classes)}")
    hull_at, hull_xy = g["hull_offsets"][()], g["hull_xy"][()]
    counts_at = g["counts_offsets"][()]
    for name, offsets, total in (("hull", hull_at, len(hull_xy)), ("counts", counts_at, g["counts_index"].shape[0])):
        if len(offsets) != n + 1 or offsets[0] != 0 or offsets[-1] != total or np.any(np.diff(offsets) < 0):
            raise damaged(f"its {name} offsets do not match its {name} data")
    columns["hull"] = [hull_xy[hull_at[i]:hull_at[i + 1]] for i in range(n)]
    columns["counts_offsets"] = counts_at
    return header, columns


def read_counts(path, rows, offsets):
    """{row: (flat indices, counts)} of the tiles ``rows`` of a catalogue (``offsets`` its
    ``counts_offsets``), read from the file without loading the others."""
    with _open(path) as f:
        index, value = f["tiles/counts_index"], f["tiles/counts_value"]
        out = {}
        for i in rows:
            lo, hi = int(offsets[i]), int(offsets[i + 1])
            out[i] = (index[lo:hi].astype(np.int64), value[lo:hi].astype(np.int64))
        return out
