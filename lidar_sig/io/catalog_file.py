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
import os
import math
from pathlib import Path

import numpy as np

from ..method.classes import recorded_table
from ..method.crs import same_crs
from ..base.errors import LidarSigError, as_path, special_file
from ..metrics import FV_GRID, MAX_COLOR_BINS, METRIC, METRIC_KEYS, SEMANTIC_KEYS, fv_mixture
from ..method.signature_raster import EGEOM_BINS, METHOD_KEYS, Frame
from ._h5datasets import described_dataset, hdf5_output

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
    crs_list, crs_index = _same_crs_once(crs_list, [crs_list.index(t["crs"] or "") for t in tiles])
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
                data = np.asarray(crs_index, np.int64)
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


def is_catalog(path: str | os.PathLike[str]) -> bool:
    """Whether ``path`` is an HDF5 file marked as a survey catalogue."""
    import h5py

    if not Path(path).is_file():  # a FIFO would be waited on
        return False
    try:
        with h5py.File(path, "r") as f:
            return f.attrs.get("format") == FORMAT
    except (OSError, ValueError):
        return False


def refuse_catalog(path, wanted):
    """Refuse a survey catalogue given where ``wanted`` (an archive, a point cloud) is expected:
    a LidarSigError saying what it is and what to do with it, or what is damaged in it. Returns
    when ``path`` is not a catalogue."""
    if is_catalog(path):
        read_catalog(path)  # a damaged catalogue says what is wrong
        raise LidarSigError(f"is a survey catalogue, not {wanted}; ask it with `lidar-sig similar` or "
                            "`lidar-sig outliers`, or give a tile's cloud or archive", path=path)


def read_catalog(path):
    """(header, columns) of a catalogue: the header as :func:`write_catalog` takes it (``crs``
    added: the list of WKT), the per-tile columns of COLUMNS as arrays (text as lists of str),
    ``hull`` a list of (K, 2) arrays and ``counts_offsets``; the counts themselves are read per
    tile (:func:`read_counts`). Every part is checked, as a signature archive's are when loaded
    (shapes, ranges, finite values, the counts against the totals, the method, the spreads): a
    damaged or hand-edited catalogue gives a LidarSigError naming the file and what is wrong.
    Tiles whose CRSs are the same CRS written differently (:func:`lidar_sig.method.crs.same_crs`)
    share one index of ``crs``."""
    with _open(path) as f:
        try:
            return _read(f, path)
        except KeyError as exc:
            raise LidarSigError(f"catalogue lacks {exc}; it is damaged or incomplete", path=path) from None
        except (TypeError, ValueError, IndexError, OSError) as exc:
            if isinstance(exc, LidarSigError):
                raise LidarSigError(str(exc).removeprefix(f"{path}: "), path=path) from None
            raise LidarSigError(f"cannot be read as a catalogue ({str(exc).splitlines()[0][:120]}); it is damaged",
                                path=path) from None


def _text(ds):
    return [v.decode() if isinstance(v, bytes) else str(v) for v in ds[()]]


def _json(attrs, name, kind, damaged):
    """The JSON attribute ``name``, which must be a ``kind`` (dict or list)."""
    try:
        value = json.loads(attrs[name])
    except (TypeError, ValueError):
        raise damaged(f"its {name} attribute is not JSON") from None
    if not isinstance(value, kind):
        raise damaged(f"its {name} attribute is not a JSON {'object' if kind is dict else 'list'}")
    return value


def _read(f, path):
    def damaged(what):
        return LidarSigError(f"{what}; the catalogue is damaged or was edited by hand: make it again "
                             "(lidar-sig catalog TILES -o FILE.h5 --overwrite)", path=path)

    table = _json(f.attrs, "classes", dict, damaged)
    try:
        classes = recorded_table(table["name"], table["names"], table["codes"], table["colors"], table.get("noise"))
    except (KeyError, TypeError, ValueError):
        raise damaged("its class table is not readable") from None
    method = _json(f.attrs, "method", dict, damaged)
    missing = [k for k in METHOD_KEYS if k not in method]
    if missing:
        raise damaged(f"its method record lacks {', '.join(missing)}")
    try:
        frame = Frame(int(f.attrs["frame_size"]), int(f.attrs["frame_margin"]))
    except (TypeError, ValueError) as exc:
        raise damaged(f"its frame is not one lidar_sig makes ({str(exc).removeprefix('signature ')})") from None
    header = {"method": method, "classes": classes, "frame": frame, "render": str(f.attrs["render"]),
              "color_bins": int(f.attrs["color_bins"]), "spread": _spread(f.attrs, classes, damaged),
              "crs": _text(f["crs"])}
    g = f["tiles"]
    n = int(g.attrs["n_tiles"])
    columns = {}
    for name, (dtype, _, _) in COLUMNS.items():
        data = _text(g[name]) if dtype == "str" else g[name][()]
        if len(data) != n:
            raise damaged(f"its column {name} has {len(data)} rows, not {n}")
        columns[name] = data
    _check_columns(columns, header, n, damaged)
    hull_at, hull_xy = g["hull_offsets"][()], g["hull_xy"][()]
    counts_at = g["counts_offsets"][()]
    for name, offsets, total in (("hull", hull_at, len(hull_xy)), ("counts", counts_at, g["counts_index"].shape[0])):
        if len(offsets) != n + 1 or offsets[0] != 0 or offsets[-1] != total or np.any(np.diff(offsets) < 0):
            raise damaged(f"its {name} offsets do not match its {name} data")
    if hull_xy.ndim != 2 or hull_xy.shape[1] != 2 or not np.isfinite(hull_xy).all():
        raise damaged("its footprints (hull_xy) are not finite x, y pairs")
    _check_counts(g, counts_at, columns, len(classes) * frame.size ** 2, damaged)
    columns["hull"] = [hull_xy[hull_at[i]:hull_at[i + 1]] for i in range(n)]
    columns["counts_offsets"] = counts_at
    header["crs"], columns["crs"] = _same_crs_once(header["crs"], columns["crs"])
    return header, columns


def _spread(attrs, classes, damaged):
    """The metrics' spreads: a positive number for every metric the catalogue compares (the
    semantic ones only when it has classes): each of lidar_sig's own, and those of other
    packages installed when it was made (one installed later is not compared)."""
    spread = _json(attrs, "spread", dict, damaged)
    wanted = [k for k in METRIC_KEYS if (classes.names or k not in SEMANTIC_KEYS)
              and (k in spread or METRIC[k].built_in)]
    missing = [k for k in wanted if k not in spread]
    if missing:
        raise damaged(f"its spread lacks the metric{'s' if len(missing) > 1 else ''} {', '.join(missing)}")
    for k in wanted:
        v = spread[k]
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or v <= 0:
            raise damaged(f"its spread of {k} is {v!r}, not a positive number")
    return {k: float(spread[k]) for k in wanted}


#: Most values of the sparse counts read at once when a catalogue is checked (16 MiB).
COUNTS_SLICE = 1 << 20
#: Per-tile columns of whole numbers that count points (never negative).
_COUNT_COLUMNS = ("n_points", "n_undefined", "n_signature", "class_totals", "egeom")


def _check_columns(c, header, n, damaged):
    """Every column of the right width, kind and range."""
    classes, bins = header["classes"], header["color_bins"]
    fv_length = 5 * len(fv_mixture(FV_GRID)[0])  # per Gaussian: its weight, mean (2) and sigma (2)
    widths = {"factors": 3, "bounds": 4, "class_totals": len(classes), "egeom": EGEOM_BINS,
              "color": bins ** 3 if 2 <= bins <= MAX_COLOR_BINS else -1, "fv": fv_length}
    for name, width in widths.items():
        shape = np.shape(c[name])
        if n and (len(shape) != 2 or shape[1] != width):
            raise damaged(f"its column {name} has shape {shape}, not ({n}, {width})")
    if not n:
        return
    if c["crs"].min() < 0 or c["crs"].max() >= len(header["crs"]):
        raise damaged("a tile's CRS index is out of range")
    for name in _COUNT_COLUMNS:
        if c[name].dtype.kind not in "iu" or c[name].min() < 0:
            raise damaged(f"its column {name} holds {'negative' if c[name].dtype.kind in 'iu' else 'non-whole'} "
                          "counts")
    for name in ("factors", "bounds", "area", "fv", "color"):
        if not np.isfinite(c[name]).all():
            raise damaged(f"its column {name} holds values that are not finite (NaN or infinite)")
    if np.any(c["factors"] <= 0) or np.any(c["area"] < 0) or np.any(c["color"] < 0):
        raise damaged("its columns factors, area or color hold negative values")
    if np.any(c["bounds"][:, :2] > c["bounds"][:, 2:]):
        raise damaged("a tile's bounds have their minimum above their maximum")
    for i in range(n):
        try:
            meta = json.loads(c["meta"][i])
        except ValueError:
            meta = None
        if not isinstance(meta, dict):
            raise damaged(f"tile {c['name'][i]}'s meta record is not a JSON object")
        n_sig = int(c["n_signature"][i])
        if int(c["egeom"][i].sum()) != n_sig or int(c["class_totals"][i].sum()) != n_sig + int(c["n_undefined"][i]) \
                or int(c["n_points"][i]) < n_sig + int(c["n_undefined"][i]):
            raise damaged(f"tile {c['name'][i]}'s Egeom histogram, class totals and point counts disagree")


def _check_counts(g, offsets, columns, size, damaged):
    """The sparse counts: indices within the count raster (``size`` pixels of all classes),
    positive values summing to each tile's points (``columns``' n_signature); read in slices of
    whole tiles."""
    n_signature = columns["n_signature"]
    index, value = g["counts_index"], g["counts_value"]
    if index.dtype.kind not in "iu" or value.dtype.kind not in "iu" or index.shape != value.shape:
        raise damaged("its counts are not whole numbers of one length")
    lo = 0
    while lo < len(offsets) - 1:
        hi = lo + 1
        while hi < len(offsets) - 1 and offsets[hi + 1] - offsets[lo] <= COUNTS_SLICE:
            hi += 1
        at, counts = index[offsets[lo]:offsets[hi]], value[offsets[lo]:offsets[hi]]
        if len(at) and (at.min() < 0 or at.max() >= size):
            raise damaged(f"its counts index pixels outside the count raster (0 to {size - 1:,})")
        if len(counts) and counts.min() <= 0:
            raise damaged("its counts hold values that are not positive")
        starts = offsets[lo:hi] - offsets[lo]
        sums = np.add.reduceat(counts.astype(np.int64), starts) if len(counts) else np.zeros(hi - lo, np.int64)
        sums[np.diff(offsets[lo:hi + 1]) == 0] = 0  # reduceat gives the next value for an empty tile
        bad = np.flatnonzero(sums != n_signature[lo:hi])
        if len(bad):
            i = lo + int(bad[0])
            raise damaged(f"the counts of its tile {columns['name'][i]} hold {int(sums[bad[0]]):,} points, its "
                          f"column n_signature {int(n_signature[i]):,}")
        lo = hi


def _same_crs_once(crs_list, indices):
    """The CRS list without the same CRS written twice (say a name-only variant, or a legacy WKT
    with TOWGS84: :func:`lidar_sig.method.crs.same_crs`), and the tiles' indices into it."""
    first = []
    for k, wkt in enumerate(crs_list):
        first.append(next((j for j in range(k) if first[j] == j and _same(crs_list[j], wkt)), k))
    if first == list(range(len(crs_list))):
        return crs_list, np.asarray(indices, np.int64)
    kept = sorted(set(first))
    return [crs_list[k] for k in kept], np.array([kept.index(first[k]) for k in indices], np.int64)


def _same(a, b):
    """Two CRS texts of a catalogue ('' for none) are the same CRS; an unreadable one is only itself."""
    try:
        return same_crs(a or None, b or None)
    except Exception:  # pyproj cannot read one of them: the tiles stay apart
        return False


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
