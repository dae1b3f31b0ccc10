"""Making and growing a catalogue: one task per tile on the run's backend (this process, local
processes or a Dask cluster, :mod:`lidar_sig.tiling.backends`), each writing its result to the
work folder whole or not at all; then the tiles merged with those already in the catalogue, the
metrics' spreads computed over all of them, and the catalogue written at once.

Growing: a tile already in the catalogue with the same path and SHA-256 is not computed again; a
changed file is; tiles of the catalogue not among the inputs stay. A catalogue holds one method:
method options that differ from its own are refused, and without any the catalogue's method is
used. ``resume`` reuses the tiles an interrupted or failed run finished in the work folder.

Copies: tiles that are identical files (the same SHA-256), or other files holding the same
points (a tile and its COPC copy: the same count, bounds, class totals and signature), are kept,
and said in a note: each would be the other's nearest tile and bend every statistic.
"""
from __future__ import annotations

import copy
import os
import time
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ..base.errors import LidarSigError, LidarSigWarning, a_kind, arg, as_path, reason
from ..base.progress import progress, step
from ._distances import spreads
from ._features import COLOR_BINS, RENDER, Features, sg_image
from ._tile import result_path, tile_task

if TYPE_CHECKING:
    from ..pipeline.flow import Pipeline

#: Fields of a finished tile kept in the catalogue (besides the work folder's key).
_TILE_FIELDS = ("path", "sha256", "crs", "factors", "n_points", "n_undefined", "n_signature", "bounds", "hull",
                "area", "density", "class_totals", "egeom", "counts_at", "counts", "fv", "color", "meta")


@dataclass
class CatalogRun:
    """What making or growing a catalogue did: the tiles ``added``, ``updated`` (changed files),
    ``unchanged`` and ``resumed`` (paths), those that ``failed`` (path -> reason), the tiles
    the catalogue holds and their CRSs (WKT, None for none), the ``duplicates`` among them
    ([(kind, [names])], :func:`duplicates`), where it ran and how long it took."""

    output: str
    added: list = field(default_factory=list)
    updated: list = field(default_factory=list)
    unchanged: list = field(default_factory=list)
    resumed: list = field(default_factory=list)
    failed: dict = field(default_factory=dict)
    n_tiles: int = 0
    method: dict = field(default_factory=dict)
    crs: list = field(default_factory=list)
    seconds: float = 0.0
    execution: str = ""
    grown: bool = False
    duplicates: list = field(default_factory=list)

    @property
    def complete(self):
        return not self.failed

    @property
    def missing(self):
        """Lines naming the tiles that failed and why."""
        return [f"{Path(p).name}: {why}" for p, why in self.failed.items()]


def build_catalog(inputs: Any, output: str | os.PathLike[str], pipeline: Pipeline | None = None, *, backend: Any = None,
                  work: str | os.PathLike[str] | None = None, resume: bool = False, overwrite: bool = False,
                  method_given: Any = None, progress_enabled: bool | None = None) -> CatalogRun:
    """Make the catalogue ``output`` (.h5) of the LAS/LAZ files and folders ``inputs``, or grow
    it when it exists (unless ``overwrite``: made anew). ``pipeline`` is the method (default
    ``Pipeline()``, or the catalogue's own when growing); ``method_given``, the method options a
    user set, must then agree with the catalogue's (None: compare the whole method, as Python
    callers passing a pipeline mean it). ``backend`` from :func:`lidar_sig.tiling.backends.executor`
    (default this process); ``work`` the folder of finished tiles (default ``OUTPUT.work``),
    removed after a complete run. Returns a :class:`CatalogRun`."""
    from ..io import HDF5_EXTENSIONS, check_output
    from ..io.atomic import exclusive_output
    from ..pipeline.flow import pipeline_or_default
    from ..tiling.sources import expand
    from ..tiling.work import work_scope

    start = time.perf_counter()
    given = pipeline is not None
    pipeline = pipeline_or_default(pipeline)  # a LidarSigError for anything but a Pipeline
    output = as_path(output, "the catalogue's output")
    if output.suffix.lower() not in HDF5_EXTENSIONS:
        raise LidarSigError("a catalogue is written as .h5", path=output)
    if isinstance(inputs, (str, Path)):
        inputs = [inputs]
    if inputs is not None and not isinstance(inputs, (list, tuple)):
        raise LidarSigError(f"inputs must be a path or a list of LAS/LAZ tiles and folders, got {a_kind(inputs)}")
    if not inputs:
        raise LidarSigError("give at least one LAS/LAZ tile or folder of tiles")
    # copies are not refused: each tile keeps its own signature, and the catalogue names tiles
    # that hold the same points (a tile and its COPC copy, a file delivered twice)
    files = [str(f) for f in expand(inputs, distinct=False)]
    check_output(output, overwrite=True)  # its folder; the catalogue itself is read once held
    work = Path(as_path(work, "work")) if work is not None else output.with_name(output.name + ".work")
    # one run at a time: two runs growing it at once would each write the tiles it read and its
    # own, and the last to finish would drop the other's; the work folder is let go at the end
    # (kept only with finished tiles, for a resumed run)
    with exclusive_output(output, "making or growing"), work_scope(work):
        return _build(files, output, pipeline, given, start, backend=backend, work=work, resume=resume,
                      overwrite=overwrite, method_given=method_given, progress_enabled=progress_enabled)


def _build(files, output, pipeline, given, start, *, backend, work, resume, overwrite, method_given,
           progress_enabled):
    """:func:`build_catalog` once the catalogue is held: read it, compute the tiles, write it."""
    from ..io import check_output
    from ..io.catalog_file import is_catalog, read_catalog
    from ..tiling.backends import InProcess
    from ..tiling.work import WorkFolderError, prepare_work, remove_work

    old = None
    if output.exists() and not overwrite:
        if not is_catalog(output):
            raise LidarSigError(f"exists and is not a lidar_sig survey catalogue; give a new name, or "
                                f"{arg('overwrite', True)} to replace it", path=output)
        old = read_catalog(output)
        pipeline = _growing_pipeline(old[0], pipeline if given else None, method_given, output)
    else:
        check_output(output, overwrite=overwrite)
    backend = backend or InProcess()
    if not callable(getattr(backend, "run", None)):
        raise LidarSigError(f"backend must be one of lidar_sig.executor(...), got {a_kind(backend)}")
    named = work  # as the user gave it, for messages
    work = prepare_work(work, resume, keep=[*files, output])
    run = CatalogRun(str(output), execution=backend.description, grown=old is not None)
    pipeline.announce_compilation()  # the workers compile in silence
    quiet = copy.copy(pipeline)
    quiet.progress = False  # workers show nothing; this process shows tiles done
    known = dict(zip(old[1]["path"], old[1]["sha256"])) if old else {}
    tasks = [(str(work), f, quiet, known.get(f)) for f in files]
    finished = []
    for (_, path, _, _), summary, err in progress(backend.run(tile_task, tasks), total=len(tasks), desc="tiles",
                                                  enabled=progress_enabled, unit="tile"):
        if isinstance(err, WorkFolderError):  # every tile would fail so: the run stops, naming the folder
            raise LidarSigError(f"cannot be used as the work folder ({err}); free some space or give "
                                f"{arg('work_dir')} another folder", path=named)
        if err is not None:
            run.failed[path] = _reason(err)
        elif summary.get("unchanged"):
            run.unchanged.append(path)
        else:
            (run.updated if path in known else run.added).append(path)
            if summary.get("resumed"):
                run.resumed.append(path)
            finished.append(path)
    if not finished and old is None and run.failed:  # nothing to write: the inputs are at fault
        remove_work(work)
        if len(files) == 1:
            raise LidarSigError(run.failed[files[0]], path=files[0])
        raise LidarSigError(f"no catalogue written: none of the {len(files)} tiles could be computed ("
                            + "; ".join(run.missing[:3]) + ("; ..." if len(run.missing) > 3 else "") + ")")
    if finished or old is None or overwrite:
        tiles = _merge(old, [_load(work, p) for p in sorted(finished)], output)
        if tiles:
            _write(output, pipeline, tiles, overwrite=old is not None or overwrite, progress_enabled=progress_enabled)
            run.duplicates = [(kind, [tiles[i]["name"] for i in group]) for kind, group in duplicates(
                *(np.array([t[k] for t in tiles]) for k in ("sha256", "n_points", "bounds", "class_totals", "fv")))]
            for kind, group in run.duplicates:
                warnings.warn(duplicate_note(kind, group), LidarSigWarning, stacklevel=2)
    if output.exists():
        header, columns = read_catalog(output)
        run.n_tiles = len(columns["name"])
        run.method = header["method"]
        run.crs = [header["crs"][k] or None for k in sorted(set(columns["crs"].tolist()))]
    if run.complete:
        remove_work(work)
    run.seconds = time.perf_counter() - start
    return run


def duplicates(sha256, n_points, bounds, class_totals, fv):
    """Groups of tiles that copy one another, per tile (arrays of N rows): [(kind, [rows])], kind
    ``"identical files"`` (the same SHA-256) or ``"the same points"`` (other files with the same
    point count, bounds, class totals and Fisher vector: the same points stored otherwise, e.g. as
    COPC, whose saliency and so signature do not depend on the order of the points)."""
    groups, by_file, by_points = [], {}, {}
    for i, h in enumerate(sha256):
        by_file.setdefault(str(h), []).append(i)
    for group in by_file.values():
        if len(group) > 1:
            groups.append(("identical files", group))
        key = (int(n_points[group[0]]), np.asarray(bounds[group[0]], np.float64).tobytes(),
               np.asarray(class_totals[group[0]]).tobytes(), np.asarray(fv[group[0]]).tobytes())
        by_points.setdefault(key, []).append(group[0])  # one file stands for its identical copies
    groups += [("the same points", group) for group in by_points.values() if len(group) > 1]
    return sorted(groups, key=lambda g: g[1])


def duplicate_note(kind, names):
    """The note about tiles ``names`` that copy one another (:func:`duplicates`)."""
    what = ("are identical files (the same SHA-256)" if kind == "identical files" else
            "hold the same points in different files (a copy, e.g. COPC)")
    return (f"tiles {', '.join(names[:-1])} and {names[-1]} {what}: each is the other's nearest tile, which bends "
            f"similar and outliers; keep one (make the catalogue anew with {arg('overwrite', True)} from the tiles "
            "without the copy)")


def _growing_pipeline(header, pipeline, method_given, output):
    """The catalogue's own method, refusing method options that differ from it."""
    from ..pipeline.flow import Pipeline
    from ..method.signature_raster import method_differences

    if pipeline is not None and (method_given is None or method_given):
        differ = method_differences(header["method"], pipeline.method())
        if "classes" in (method_given or {"classes"}) and pipeline.classes != header["classes"]:
            differ.append(f"class table {header['classes'].name} / {pipeline.classes.name}")
        if differ:
            raise LidarSigError("holds tiles made with another method (" + "; ".join(differ) + "); a catalogue "
                                "holds one method: leave out the method options to grow it, or write a new one",
                                path=output)
    progress_setting = getattr(pipeline, "progress", None)
    return Pipeline.from_method(header["method"], classes=header["classes"], frame=header["frame"],
                                progress=progress_setting)


def _reason(err):
    if isinstance(err, LidarSigError):  # the file is named where the reason is printed
        text = str(err)
        return text[len(err.path) + 2:] if err.path and text.startswith(err.path) else text
    return f"{type(err).__name__}: {reason(err)}"


def _load(work, path):
    """A finished tile's fields from the work folder."""
    with np.load(result_path(work, path)) as r:
        tile = {k: r[k] for k in _TILE_FIELDS}
    for k in ("path", "sha256", "crs", "meta"):
        tile[k] = str(tile[k])
    for k in ("n_points", "n_undefined", "n_signature"):
        tile[k] = int(tile[k])
    for k in ("area", "density"):
        tile[k] = float(tile[k])
    tile["name"] = Path(tile["path"]).name
    return tile


def _merge(old, new, output):
    """The catalogue's tiles (``old``: its header and columns, or None) with ``new`` ones
    replacing those of the same path, in path order."""
    from ..io.catalog_file import read_counts

    tiles = {t["path"]: t for t in new}
    if old is not None:
        header, c = old
        keep = [i for i, p in enumerate(c["path"]) if p not in tiles]
        counts = read_counts(output, keep, c["counts_offsets"]) if keep else {}
        for i in keep:
            tile = {k: c[k][i] for k in ("name", "path", "sha256", "factors", "n_points", "n_undefined",
                                        "n_signature", "bounds", "area", "density", "class_totals", "egeom", "fv",
                                        "color", "meta")}
            tile["crs"] = header["crs"][int(c["crs"][i])]
            tile["hull"] = c["hull"][i]
            tile["counts_at"], tile["counts"] = counts[i]
            tiles[tile["path"]] = tile
    return [tiles[p] for p in sorted(tiles)]


def _write(output, pipeline, tiles, *, overwrite, progress_enabled=None):
    """The spreads over ``tiles``, then the catalogue written."""
    from ..io.catalog_file import write_catalog

    frame = pipeline.frame
    features = Features(*(np.array([t[k] for t in tiles]) for k in ("fv", "color", "egeom", "class_totals",
                                                                     "n_signature")))
    pixels = frame.size ** 2

    def sg_of(i):
        total = np.bincount(np.asarray(tiles[i]["counts_at"]) % pixels, weights=tiles[i]["counts"], minlength=pixels)
        return sg_image(total.reshape(frame.size, frame.size), features.n_points[i], frame)

    with step("spreads of the metrics", enabled=progress_enabled, tiles=len(tiles)):
        spread = spreads(features, sg_of, frame.mask(), bool(pipeline.classes.names))
    header = {"method": pipeline.method(), "classes": pipeline.classes, "frame": frame, "render": RENDER,
              "color_bins": COLOR_BINS, "spread": spread}
    with step(f"writing {output.name}", enabled=progress_enabled, tiles=len(tiles)):
        write_catalog(output, header, tiles, overwrite=overwrite)
