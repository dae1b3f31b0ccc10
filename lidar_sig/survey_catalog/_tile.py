"""One tile of a catalogue, a task for a worker: its SHA-256, its own signature (saliency computed
on the tile alone, as a query cloud's is), footprint, point count, density, class counts, CRS and
per-tile features, written to the work folder whole or not at all.

A tile of more than ``BLOCK_POINTS`` points goes through the tiled runner
(:func:`lidar_sig.tiling.run_set.run_set`, in the worker itself), which gives the one-block
signature without holding the tile whole; its footprint is then gathered chunk by chunk.
A LAS/LAZ tile whose class codes are all 0 ("created, never classified") is counted in that
class rather than as unlabelled, so that it stays comparable with the others: it is the tile a
quality check is looking for.
"""
from __future__ import annotations

import json
import os
import time
from pathlib import Path

import numpy as np

from ..base.errors import LidarSigError
from ..numerics.bounds import column_max, column_min
from ._features import signature_features
from ._footprint import convex_hull, hull_of_hulls, polygon_area

#: Points above which a tile is computed through the tiled runner (what a worker holds in one
#: block: about 0.5 GiB, see docs/scale-out.md).
BLOCK_POINTS = 2_000_000
#: Version of what a finished tile holds; a work folder of another version is not reused.
TILE_VERSION = 1


def result_path(work, path):
    """The file of the tile ``path``'s result in the work folder."""
    import hashlib

    from ..tiling.work import FINISHED

    tag = hashlib.sha1(str(path).encode()).hexdigest()[:12]
    return Path(work) / FINISHED / f"{Path(path).stem}.{tag}.npz"


def tile_key(sha256, pipeline):
    """Changes whenever a tile's result would: its content, the method, class table and frame."""
    return json.dumps([TILE_VERSION, sha256, pipeline.method(), pipeline.classes.name, pipeline.frame.size,
                       pipeline.frame.margin], default=str)


def tile_task(work, path, pipeline, known_sha256=None):
    """Compute one tile and write its result to ``work`` (a task); returns a small summary.

    ``known_sha256`` is the tile's digest in the catalogue being grown: when the file still has
    it, nothing is computed (``{"unchanged": True}``). A result of the same content and method
    already in ``work`` (an interrupted run, resumed) is reused."""
    from ..io.archive import sha256_of

    path = str(path)
    sha = sha256_of(path)
    if sha == known_sha256:
        return {"path": path, "sha256": sha, "unchanged": True}
    key = tile_key(sha, pipeline)
    out = result_path(work, path)
    if out.is_file():
        with np.load(out) as done:
            if str(done["key"]) == key:
                return {"path": path, "sha256": sha, "resumed": True, "n_points": int(done["n_points"])}
    t0 = time.perf_counter()
    signature, crs, factors, bounds, hull, tiled = _signature_and_footprint(path, pipeline, Path(work))
    area = polygon_area(hull) * factors[0] * factors[1]  # square metres
    features = signature_features(signature)
    meta = signature.metadata
    n_points = int(meta.get("n_points", signature.n_points))
    record = {"resolved_scales": list(meta.get("resolved_scales", [])), "units": meta.get("units"),
              "n_capped": int(meta.get("n_capped", 0)), "n_duplicates": int(meta.get("n_duplicates", 0)),
              "tiled": tiled, "seconds": round(time.perf_counter() - t0, 3)}
    flat = signature.counts.ravel()
    nz = np.flatnonzero(flat)
    tmp = out.with_name(f".{out.stem}.{os.getpid()}.tmp.npz")
    try:
        out.parent.mkdir(parents=True, exist_ok=True)
        np.savez(tmp, key=np.array(key), path=np.array(path), sha256=np.array(sha), crs=np.array(crs or ""),
                 factors=np.asarray(factors, np.float64), n_points=n_points, n_undefined=int(signature.n_undefined),
                 n_signature=int(signature.n_points),
                 bounds=np.asarray(bounds, np.float64), hull=hull, area=area,
                 density=n_points / area if area > 0 else np.nan, class_totals=signature.class_totals,
                 egeom=signature.egeom_counts, counts_at=nz, counts=flat[nz], fv=features.fv[0],
                 color=features.color[0], meta=np.array(json.dumps(record)))
        os.replace(tmp, out)  # a tile's result exists whole or not at all
    except OSError as exc:  # the work folder's disk (full, read-only) failed, not the tile
        from ..base.errors import reason
        from ..tiling.work import WorkFolderError

        tmp.unlink(missing_ok=True)
        raise WorkFolderError(f"{exc.strerror or reason(exc)} while keeping the result of {Path(path).name}") from None
    return {"path": path, "sha256": sha, "n_points": n_points}


def _signature_and_footprint(path, pipeline, work):
    """(signature, CRS WKT or None, metres per unit, bounds, hull, tiled) of one tile."""
    import laspy

    from ..io.las import read_las

    try:
        with laspy.open(path) as reader:
            n = int(reader.header.point_count)
    except Exception as exc:  # laspy raises many kinds on a damaged header
        from ..base.errors import reason

        raise LidarSigError(f"cannot be read as LAS/LAZ ({reason(exc)}); check that the file is complete",
                            path=path) from None
    if n > BLOCK_POINTS:
        return _through_tiles(path, pipeline, work)
    cloud = read_las(path)
    if cloud.labels is None:  # class 0 everywhere: counted in that class (module docstring)
        cloud.labels = np.zeros(len(cloud), np.int64)
    signature = pipeline.run(cloud).signature
    xy = cloud.xyz[:, :2]
    bounds = (*column_min(xy), *column_max(xy))
    return signature, cloud.crs, cloud.units.factors, bounds, convex_hull(xy), False


def _through_tiles(path, pipeline, work):
    """A tile too large for one block: its signature from the tiled runner, its footprint from
    the hulls of its chunks."""
    import copy

    import laspy

    from ..io.las import las_xyz
    from ..tiling.backends import InProcess
    from ..tiling.run_set import run_set
    from ..tiling.work import remove_work

    quiet = copy.copy(pipeline)
    quiet.progress = False
    sub = work / "blocks" / result_path(work, path).stem
    sub.parent.mkdir(exist_ok=True)  # inside the catalogue's work folder, which exists
    run = run_set(quiet, [path], work=sub, backend=InProcess(), progress_enabled=False)
    if not run.complete:
        remove_work(sub)  # a resumed catalogue computes the tile anew
        raise LidarSigError("could not be computed in tiles: " + "; ".join(run.missing), path=path)
    signature = _in_table(run.signature, pipeline.classes)
    hulls = []
    with laspy.open(path) as reader:
        lo, hi = reader.header.mins, reader.header.maxs
        for chunk in reader.chunk_iterator(500_000):
            hulls.append(convex_hull(las_xyz(chunk)[:, :2]))
    remove_work(sub)
    source = run.sources[0]
    bounds = (float(lo[0]), float(lo[1]), float(hi[0]), float(hi[1]))
    return signature, source.crs, source.factors, bounds, hull_of_hulls(hulls), True


def _in_table(signature, classes):
    """A signature of a tile without class codes (all 0) counted in the class of code 0 of
    ``classes``, as the block path counts it."""
    from ..method.signature_raster import Signature

    if signature.classes == classes:
        return signature
    k = int(classes.index(np.array([0]))[0])
    counts = np.zeros((len(classes),) + signature.counts.shape[1:], np.int64)
    counts[k] = signature.counts.sum(axis=0)
    totals = np.zeros(len(classes), np.int64)
    totals[k] = int(np.sum(signature.class_totals))
    return Signature(counts, signature.frame, classes, signature.egeom_counts, signature.n_undefined,
                     signature.metadata, totals)
