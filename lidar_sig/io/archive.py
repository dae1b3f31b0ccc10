"""HDF5 signature archives (docs/archive.md): signature, renderings, histograms, per-point saliency.

Self-describing: every dataset carries ``description`` and, where it has one, ``units``;
the root attributes say which program, version, descriptor, strategy and scales made it and
from which files (with SHA-256). docs/archive.md lists the layout. Written atomically.
"""
from __future__ import annotations

import hashlib
import json

import numpy as np

from ..method.classes import recorded_table
from ..base.errors import LidarSigError, as_path, counted, special_file
from ..method.saliency_map import LN3
from ..method.scales import ScaleKind, recorded_kind
from ..method.signature_raster import METHOD_KEYS, Frame, Signature
from ._h5datasets import described_dataset, hdf5_output
from .formats import HDF5_EXTENSIONS  # noqa: F401 (a name of this module too)

FORMAT = "lidar_sig signature archive"
FORMAT_VERSION = 2
# Root attributes copied from the signature's metadata, as text and as integers.
_TEXT_ATTRS = ("descriptor", "strategy", "scales", "scale_kind", "scale_units", "weights", "units", "crs")
_INT_ATTRS = ("n_points", "n_undefined", "n_capped", "n_duplicates", "n_excluded", "max_neighbors",
              "min_neighbors")


def sha256_of(path):
    """SHA-256 hex digest of a file."""
    digest = hashlib.sha256()
    with open(path, "rb") as fh:
        for chunk in iter(lambda: fh.read(1 << 20), b""):
            digest.update(chunk)
    return digest.hexdigest()


def write_archive(path, signature, *, saliency=None, labels=None, sources=(), render="smooth",
                  overwrite=False, tiling=None):
    """Write ``signature`` (and, if given, per-point ``saliency`` and ``labels``) to ``path``.

    ``sources`` are the point-cloud files it was made from (paths, or ``{"path", "sha256"}``
    records already hashed); their SHA-256 is recorded. ``tiling`` (a dict) records how a set
    of tiles was processed (attribute ``tiling``, JSON; absent for one block). The stored Sg
    and Sas images are rendered as ``render``; the counts keep every rendering.
    """
    meta = dict(signature.metadata)
    source_list = [dict(p) if isinstance(p, dict) else {"path": str(p), "sha256": sha256_of(p)} for p in sources]
    with hdf5_output(path, FORMAT, FORMAT_VERSION, overwrite=overwrite) as f:
        f.attrs["sources"] = json.dumps(source_list)
        if tiling is not None:
            f.attrs["tiling"] = json.dumps(tiling)
        f.attrs["method"] = json.dumps({k: meta[k] for k in METHOD_KEYS if k in meta})
        f.attrs["render"] = render
        for key in _TEXT_ATTRS:
            if meta.get(key) is not None:
                f.attrs[key] = str(meta[key])
        # the totals the loader checks the parts against come from the parts themselves (a
        # sum of signatures keeps the metadata of its first term); the points of the cloud
        # are those of the signature and those the run left out, as the run counts them
        meta["n_points"] = int(signature.class_totals.sum()) + int(meta.get("n_excluded", 0))
        meta["n_undefined"] = int(signature.n_undefined)
        for key in _INT_ATTRS:
            if key in meta:
                f.attrs[key] = int(meta[key])
        if "resolved_scales" in meta:
            kind = recorded_kind(meta) or ScaleKind.RADIUS  # neighbour counts are whole numbers
            f.attrs["resolved_scales"] = np.asarray(meta["resolved_scales"],
                                                    dtype=np.int64 if kind.by_count else np.float64)
            f.attrs["resolved_scales_units"] = kind.resolved_units
        if "metres_per_unit" in meta:
            f.attrs["metres_per_unit"] = np.asarray(meta["metres_per_unit"], dtype=np.float64)
        f.attrs["descriptor_params"] = json.dumps(meta.get("descriptor_params", {}))
        _write_signature(f.create_group("signature"), signature, render)
        if saliency is not None:
            _write_points(f.create_group("points"), saliency, labels)


def _write_signature(g, sig, render):
    frame, classes = sig.frame, sig.classes
    g.attrs["description"] = "signature: per-class count raster of saliency positions in the reference triangle"
    g.attrs["frame_size"] = frame.size
    g.attrs["frame_margin"] = frame.margin
    g.attrs["n_undefined"] = sig.n_undefined
    dtype = np.uint32 if sig.counts.max(initial=0) < 2**32 else np.uint64
    described_dataset(g, "counts", sig.counts.astype(dtype),
                      "points of each class (axis 0, class table order) per pixel (row, col)", "points")
    sg, sas = sig.render(render)
    described_dataset(g, "sg", sg.astype(np.float32), f"geometric signature Sg, {render} rendering", "1")
    described_dataset(g, "sas", sas.astype(np.float32), f"augmented semantic signature Sas, RGB, {render} rendering",
                      "1")
    described_dataset(g, "class_totals", sig.class_totals.astype(np.int64),
                      "points of each class in the cloud, undefined saliency included (semantic metrics)", "points")
    described_dataset(g, "mask", frame.mask().astype(np.uint8), "1 for pixels of the reference triangle")
    tri = described_dataset(g, "triangle", frame.vertices,
                            "reference triangle vertices V_l, V_s, V_p (line, surface, point) as (x, y)", "pixels")
    tri.attrs["axes"] = "x to the right, y downwards, pixel (row, col) covers [col, col+1) x [row, row+1)"
    eh = described_dataset(g, "egeom_histogram", sig.egeom_counts,
                           "histogram of geometric entropy Egeom over [0, ln 3]", "points")
    eh.attrs["range"] = np.array([0.0, LN3])
    eh.attrs["range_units"] = "nats"
    sh = described_dataset(g, "saliency_histograms", saliency_histograms(sig),
                           "per class (axis 0) histograms of Cl, Cs, Cp (axis 1) over [0, 1] (axis 2), "
                           "from the pixel positions of the count raster", "points")
    sh.attrs["range"] = np.array([0.0, 1.0])
    c = g.create_group("classes")
    c.attrs["description"] = "class table: name, RGB colour and label codes per class, 'other' last"
    c.attrs["table"] = classes.name
    described_dataset(c, "names", list(classes.class_names), "class names, 'other' last")
    described_dataset(c, "colors", np.rint(classes.class_colors * 255).astype(np.uint8), "RGB colour per class",
                      "0-255")
    codes = [list(cs) for cs in classes.codes] + [[]]
    described_dataset(c, "codes", np.array([v for cs in codes for v in cs], dtype=np.int64),
                      "label codes of all classes, concatenated")
    described_dataset(c, "code_offsets", np.cumsum([0] + [len(cs) for cs in codes]).astype(np.int64),
                      "class k has codes[code_offsets[k]:code_offsets[k+1]]")
    described_dataset(c, "noise_codes", np.array(classes.noise, dtype=np.int64),
                      "label codes of noise points, left out of the run unless keep_noise")


def saliency_histograms(sig, bins=50):
    """(C, 3, bins) histograms of Cl, Cs, Cp per class from the count raster's pixel positions."""
    v = sig.frame.vertices  # V_l, V_s, V_p in pixels
    rows, cols = np.nonzero(sig.total)
    xy = np.column_stack([cols + 0.5, rows + 0.5])
    # barycentric coordinates of pixel centres: solve [V_l V_s V_p; 1 1 1] b = [x y 1]
    m = np.vstack([v.T, np.ones(3)])
    bary = np.clip(np.linalg.solve(m, np.vstack([xy.T, np.ones(len(xy))])).T, 0.0, 1.0)
    out = np.zeros((sig.counts.shape[0], 3, bins), np.int64)
    for k in range(sig.counts.shape[0]):
        w = sig.counts[k, rows, cols]
        for j in range(3):
            out[k, j], _ = np.histogram(bary[:, j], bins=bins, range=(0.0, 1.0), weights=w)
    return out


def _write_points(g, sal, labels):
    g.attrs["description"] = "per-point results, in the order of the source file's points"
    for name, data, desc in (("cl", sal.cl, "line-type saliency Cl"), ("cs", sal.cs, "surface-type saliency Cs"),
                             ("cp", sal.cp, "point-type saliency Cp")):
        described_dataset(g, name, data.astype(np.float32), desc + " (NaN where undefined)", "1")
    described_dataset(g, "egeom", sal.egeom.astype(np.float32), "geometric entropy Egeom (NaN where undefined)", "nats")
    described_dataset(g, "geom_class", sal.geom_class, "geometric class: 1 line, 2 surface, 3 point, 0 undefined")
    if sal.optimal_scale is not None:
        described_dataset(g, "optimal_scale", sal.optimal_scale.astype(np.int16),
                          "index of the chosen scale in the ascending scales, -1 if undefined")
    if labels is not None:
        described_dataset(g, "labels", np.asarray(labels).astype(np.int32), "semantic label code (ASPRS for LAS)")


def _open(path):
    """The archive open for reading, after checking it is one this version reads."""
    import h5py

    try:
        f = h5py.File(path, "r")
    except OSError as exc:
        raise LidarSigError(f"cannot be read as HDF5 ({str(exc).splitlines()[0][:120]}); "
                            "check that the file is complete", path=path) from None
    fmt, version = f.attrs.get("format"), f.attrs.get("format_version", 0)
    problem = None
    if fmt != FORMAT:
        from .catalog_file import FORMAT as CATALOG, refuse_catalog

        if fmt == CATALOG:
            f.close()
            refuse_catalog(path, "a signature archive")
        problem = ("is an HDF5 file but not a lidar_sig signature archive; make one with "
                   "`lidar-sig signature CLOUD -o OUT.h5`")
    elif not isinstance(version, (int, np.integer)) or isinstance(version, bool) or version < 1:
        problem = f"has a format_version that is not a version number ({version!r}); the archive is damaged"
    elif version > FORMAT_VERSION:
        problem = (f"archive format version {int(version)} is newer than this lidar_sig reads "
                   f"({FORMAT_VERSION}); upgrade lidar_sig")
    if problem:
        f.close()
        raise LidarSigError(problem, path=path)
    return f


def load_signature(path):
    """The Signature stored in an archive; compares exactly like the one that was written.

    Every part is checked before use (shapes, counts, the class table, the method record): a
    damaged or hand-edited archive gives a LidarSigError naming what is wrong.
    """
    path = as_path(path, "load_signature")
    if not path.is_file():
        raise LidarSigError("no such file; check the path" if not path.exists()
                            else f"is {special_file(path) or 'a folder'}, not a regular file; give a signature archive",
                            path=path)
    with _open(path) as f:
        try:
            return _read_signature(f, path)
        except KeyError:  # a part looked up without _part (the library's sentence says nothing more)
            raise LidarSigError(f"archive lacks a part lidar_sig writes; it is damaged or incomplete: {_AGAIN}",
                                path=path) from None
        except (OSError, TypeError, ValueError, IndexError) as exc:
            if isinstance(exc, LidarSigError):
                raise LidarSigError(str(exc).removeprefix(f"{path}: "), path=path) from None
            raise LidarSigError(f"cannot be read as a signature archive ({str(exc).splitlines()[0][:120]}); "
                                "it is damaged", path=path) from None


#: The fix of a damaged archive.
_AGAIN = "make it again (lidar-sig signature CLOUD -o OUT.h5)"


def _part(group, name, path):
    """``group[name]`` (a dataset or group), or a LidarSigError naming the part that is missing."""
    if name not in group:
        where = f"{group.name.strip('/')}/{name}".lstrip("/")
        raise LidarSigError(f"archive lacks {where}; it is damaged or incomplete: {_AGAIN}", path=path)
    return group[name]


def _read_signature(f, path):
    def damaged(what):
        return LidarSigError(f"{what}; the archive is damaged or was edited by hand: {_AGAIN}", path=path)

    g = _part(f, "signature", path)
    c = _part(g, "classes", path)
    names = [n.decode() if isinstance(n, bytes) else str(n) for n in _part(c, "names", path)[()]]
    colors = [tuple(int(v) for v in row) for row in _part(c, "colors", path)[()]]
    codes, offsets = _part(c, "codes", path)[()], _part(c, "code_offsets", path)[()]
    if len(colors) != len(names) or len(offsets) != len(names) + 1 or np.any(np.diff(offsets) < 0) \
            or offsets[0] != 0 or offsets[-1] != len(codes):
        raise damaged("its class table is inconsistent (names, colours and codes do not match)")
    groups = [tuple(int(v) for v in codes[offsets[k]:offsets[k + 1]]) for k in range(len(names))]
    if "table" not in c.attrs:
        raise damaged("its class table has no name (attribute table of signature/classes)")
    classes = recorded_table(str(c.attrs["table"]), names[:-1], groups[:-1], colors[:-1],
                             c["noise_codes"][()] if "noise_codes" in c else None)
    size, margin = _int_attr(g.attrs, "frame_size", damaged), _int_attr(g.attrs, "frame_margin", damaged)
    try:
        frame = Frame(size, margin)
    except LidarSigError as exc:
        raise damaged(f"its frame is not one lidar_sig makes ({str(exc).removeprefix('signature ')})") from None
    counts = _part(g, "counts", path)
    expected = (len(classes), frame.size, frame.size)
    if counts.shape != expected or counts.dtype.kind not in "iu":
        raise damaged(f"its count raster has shape {counts.shape} ({counts.dtype}), not {expected} integers "
                      "as its frame and class table say")
    counts = counts[()].astype(np.int64)
    egeom = _part(g, "egeom_histogram", path)[()]
    if egeom.ndim != 1 or not len(egeom) or egeom.dtype.kind not in "iu":
        raise damaged("its Egeom histogram is not a list of counts")
    totals = g["class_totals"][()] if "class_totals" in g else None
    if totals is not None and (totals.shape != (len(classes),) or totals.dtype.kind not in "iu"):
        raise damaged(f"its class totals have shape {totals.shape}, not ({len(classes)},)")
    n_undefined = _int_attr(g.attrs, "n_undefined", damaged)
    if counts.min(initial=0) < 0 or egeom.min(initial=0) < 0 or n_undefined < 0 \
            or (totals is not None and totals.min(initial=0) < 0):
        raise damaged("it holds negative counts")
    _check_totals(counts, egeom, totals, n_undefined, f.attrs, damaged)
    meta = {k: (v.tolist() if isinstance(v, np.ndarray) else v) for k, v in f.attrs.items()}
    try:
        meta.update(_method(f.attrs))
    except (ValueError, TypeError, AttributeError):
        raise damaged("its method record is not readable") from None
    # an archive made before withheld and noise points were left out used every point: a cloud
    # compared with it is computed so (docs/archive.md)
    meta.setdefault("keep_noise", True)
    kind = recorded_kind(meta)
    if kind is not None and kind.by_count and isinstance(meta.get("resolved_scales"), list):
        # k values as whole numbers, as the pipeline gives them (earlier archives stored floats)
        try:
            meta["resolved_scales"] = kind.typed(meta["resolved_scales"])
        except (TypeError, ValueError):
            raise damaged("its resolved scales are not numbers") from None
    return Signature(counts, frame, classes, egeom.astype(np.int64), n_undefined, meta,
                     None if totals is None else totals.astype(np.int64))


def _check_totals(counts, egeom, totals, n_undefined, attrs, damaged):
    """The parts of an archive agree with each other and with its recorded totals: the count
    raster and the Egeom histogram hold the same (defined) points; the class totals hold those
    and the undefined ones, each class at least its points in the raster; the root attributes
    n_points (those and the withheld and noise points left out, n_excluded) and n_undefined say
    the same."""
    n_defined = int(counts.sum())
    if int(egeom.sum()) != n_defined:
        raise damaged(f"its Egeom histogram counts {counted(int(egeom.sum()), 'point')} but its count raster "
                      f"{n_defined:,}")
    n_all = n_defined + n_undefined
    if totals is not None and (int(totals.sum()) != n_all or np.any(totals < counts.sum(axis=(1, 2)))):
        raise damaged(f"its class totals ({counted(int(totals.sum()), 'point')}) disagree with its count raster "
                      f"({counted(n_defined, 'point')}) and its {counted(n_undefined, 'undefined point')}")
    n_excluded = _int_attr(attrs, "n_excluded", damaged) if "n_excluded" in attrs else 0
    if n_excluded < 0:
        raise damaged("it holds negative counts")
    for name, value in (("n_points", n_all + n_excluded), ("n_undefined", n_undefined)):
        if name in attrs and _int_attr(attrs, name, damaged) != value:
            left_out = f", {counted(n_excluded, 'withheld or noise point')} left out" if n_excluded else ""
            raise damaged(f"its {name} attribute ({int(attrs[name]):,}) disagrees with its signature "
                          f"({counted(n_defined, 'point')} with a saliency, {n_undefined:,} undefined{left_out})")


def _int_attr(attrs, name, damaged):
    if name not in attrs:
        raise damaged(f"it lacks the attribute {name}")
    value = attrs[name]
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)):
        raise damaged(f"its {name} is not a whole number ({value!r})")
    return int(value)


def _method(attrs):
    """The method settings of an archive (METHOD_KEYS). Format 1 archives recorded them as
    separate attributes, with the scales as text, and weighed neighbours equally."""
    if "method" in attrs:
        method = json.loads(attrs["method"])
        if not isinstance(method, dict):
            raise ValueError("method is not a JSON object")
        return method
    text = str(attrs.get("scales", ""))
    values = [float(v) for v in text.split(" ", 1)[-1].split("(")[0].replace(",", " ").split()] if text else []
    out = {"weights": "none", "descriptor_params": json.loads(attrs.get("descriptor_params", "{}"))}
    for key in ("descriptor", "strategy", "scale_kind", "scale_units"):
        if key in attrs:
            out[key] = str(attrs[key])
    for key in ("max_neighbors", "min_neighbors"):
        if key in attrs:
            out[key] = int(attrs[key])
    if values:
        kind = recorded_kind(out)
        out["scale_values"] = kind.typed(values) if kind is not None and kind.by_count else values
    return out


#: Largest difference between a stored image and the one made again from the counts (float32 rounding).
IMAGE_TOLERANCE = 1e-4


def _stored_images(path, sig, render):
    """Whether the stored Sg and Sas images are those of the counts (metrics are computed from
    the counts, so a damaged image misleads only a reader of the file): said, with a note when
    one differs."""
    import warnings

    from ..base.errors import LidarSigWarning
    from ..method.signature_raster import RENDERINGS

    import h5py

    if render is None:
        return "not checked (no rendering recorded)"
    if render not in RENDERINGS:
        return f"not checked (the rendering {render!r} is not one lidar_sig makes)"
    made = dict(zip(("sg", "sas"), sig.render(render)))
    differ = []
    with _open(path) as f:
        for name, image in made.items():
            ds = f["signature"].get(name)
            if not isinstance(ds, h5py.Dataset):
                differ.append(f"{name} missing")
            elif ds.shape != image.shape or ds.dtype.kind not in "iuf":
                differ.append(f"{name} of shape {ds.shape} ({ds.dtype}), not {image.shape} numbers")
            else:
                gap = np.abs(ds[()].astype(np.float64) - image)
                if np.isnan(gap).any():
                    differ.append(f"{name} holds NaN")
                elif gap.max(initial=0.0) > IMAGE_TOLERANCE:
                    differ.append(f"{name} differs from its counts by up to {gap.max():.3g}")
    if not differ:
        return f"Sg and Sas agree with the counts ({render} rendering)"
    text = "; ".join(differ)
    warnings.warn(LidarSigWarning(f"{path}: its stored image {text}: the archive is damaged or was edited; metrics "
                                  f"use the counts and are not affected, but the stored picture misleads: {_AGAIN}"),
                  stacklevel=2)
    return text + " (damaged or edited)"


def archive_summary(path):
    """Lines describing an archive, for `lidar-sig info`; a damaged record is said, not fatal."""
    sig = load_signature(path)
    with _open(path) as f:
        attrs = dict(f.attrs)
        has_points = "points" in f and "cl" in f["points"]
        n_rows = f["points/cl"].shape[0] if has_points else 0
    m = sig.metadata
    lines = [f"{path}: {FORMAT} v{attrs['format_version']} (lidar_sig {attrs.get('lidar_sig_version', '?')})",
             f"  descriptor {m.get('descriptor', '?')}, strategy {m.get('strategy', '?')}, "
             f"{attrs.get('scales', '?')}, {m.get('weights', '?')} weights",
             f"  signature: {counted(sig.n_points, 'point')}, {sig.n_undefined:,} undefined, "
             f"{counted(int(m.get('n_excluded', 0)), 'withheld or noise point')} left out, frame {sig.frame.size} px, "
             f"class table {sig.classes.name!r}",
             f"  per-point datasets: {'yes, ' + format(n_rows, ',') + ' points' if has_points else 'no'}"]
    for name, count in zip(sig.classes.class_names, sig.class_totals):
        if count:
            lines.append(f"    {name}: {int(count):,}")
    lines.append(f"  stored images: {_stored_images(path, sig, attrs.get('render'))}")
    try:
        sources = json.loads(attrs.get("sources", "[]"))
        lines += [f"  source {src['path']} sha256 {src['sha256']}" for src in sources]
    except (ValueError, TypeError, KeyError):
        lines.append("  sources: unreadable (the record is not the JSON list lidar_sig writes)")
    if "tiling" in attrs:
        try:
            t = json.loads(attrs["tiling"])
            lines.append(f"  tiling: {t['tiles'][0]} x {t['tiles'][1]} tiles of {t['tile_size_m']:.4g} m, "
                         f"{counted(t['n_recomputed'], 'point')} recomputed with a wider halo")
        except (ValueError, TypeError, KeyError, IndexError):
            lines.append("  tiling: unreadable (the record is not the JSON lidar_sig writes)")
    return lines
