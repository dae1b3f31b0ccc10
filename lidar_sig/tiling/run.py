"""A set of LAS/LAZ files processed in tiles: staging, the set's context, tiles, reduce.

1. **Staging**: each file is read once, in chunks, and its points filed by plan-view cell in the
   work folder (:mod:`lidar_sig.tiling.sources`); one task per file part.
2. **Context**: the set's extent, scales and (with area weights) the area-weight cap, from a
   pass of small tasks over the tiles (:class:`lidar_sig.tiling.core.SetContext`).
3. **Tiles**: one task per processing tile computes its core points' saliency with a checked
   halo and the tile's signature, and writes them to the work folder (each file complete or
   absent, so ``resume`` can skip finished tiles).
4. **Reduce**: the set's signature is the sum of the tiles' (count rasters are additive);
   per-point outputs are gathered per input file.

A file that cannot be read and a tile that fails are recorded by name; the others go on. The
results are then those of the set without the missing file, and the set's signature is not
made: :attr:`SetRun.missing` says what is missing.
"""
from __future__ import annotations

import json
import math
import os
import shutil
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .. import __version__
from ..classes import UNLABELED
from ..errors import LidarSigError, as_path
from ..progress import progress
from ..saliency import Saliency
from ..signature import Signature
from .core import (SetContext, Tiling, _positions, area_cap, check_tile_size, check_tileable, context_of,
                   tile_name, tile_saliency, tile_second_distances)
from .sources import (Cells, cell_files, expand, load_cells, scan, source_of, index_of, stage_part, staged,
                      tile_side_for)

#: Staging cells per tile side.
CELLS_PER_TILE = 4
#: Per-point results of one input file on disk: (Cl, Cs, Cp) and the chosen scale index.
POINT_VALUES = np.dtype([("values", "f8", 3), ("chosen", "i8")])
#: Default points per processing tile (with its halo about a quarter more): what one worker
#: holds at once, about 0.5 GiB at the pipeline's 0.21 GiB per million points.
TILE_POINTS = 2_000_000
#: Fewest points a processing tile holds on average: smaller tiles are refused.
MIN_TILE_POINTS = 500


@dataclass(frozen=True)
class Plan:
    """Everything a tile task needs (small: pickled to each worker)."""

    work: str
    pipeline: object
    ctx: SetContext
    tiling: Tiling
    cells: Cells
    files: dict
    classes: object
    staged: str = ""

    def key(self):
        """Changes whenever a tile's result would: the set's files as staged (path, size, time,
        points), its context, the method and the tiling."""
        return json.dumps([self.staged, self.ctx.key(), self.pipeline.method(), self.classes.name,
                           self.pipeline.frame.size, self.tiling.size], default=str)

    def load(self, bounds):
        """(xyz centred metres, ids, labels) of the staged points within plan-view ``bounds``."""
        x0, y0, x1, y1 = bounds
        c, f = self.ctx.centre, self.ctx.factors
        raw = (x0 / f[0] + c[0], y0 / f[1] + c[1], x1 / f[0] + c[0], y1 / f[1] + c[1])
        rec = load_cells(self.files, self.cells, raw)
        xyz = self.ctx.metric(np.column_stack([rec["x"], rec["y"], rec["z"]]))
        inside = (xyz[:, 0] >= x0) & (xyz[:, 0] <= x1) & (xyz[:, 1] >= y0) & (xyz[:, 1] <= y1)
        return xyz[inside], rec["id"][inside], rec["label"][inside]

    def load_points(self, bounds):
        xyz, ids, _ = self.load(bounds)
        return xyz, ids


def result_path(work, ij):
    return Path(work) / "tiles" / f"{tile_name(*ij)}.npz"


def stage_task(work, source, part, start, stop, cells):
    """Stage one part of one file (a task)."""
    return stage_part(work, source, part, start, stop, cells)


def second_task(plan, ij):
    """Second-neighbour distances of one tile's core locations (a task)."""
    return tile_second_distances(plan.load_points, plan.tiling, ij, plan.ctx)


def tile_task(plan, ij):
    """Saliency and signature of one tile's core points, written to the work folder (a task);
    returns the tile's statistics. A result of the same set and method is reused."""
    path = result_path(plan.work, ij)
    key = plan.key()
    if path.is_file():
        with np.load(path) as done:
            if str(done["key"]) == key:
                return {**json.loads(str(done["stats"])), "resumed": True}
    t0 = time.perf_counter()
    r = tile_saliency(plan.pipeline, plan.load_points, plan.tiling, ij, plan.ctx)
    # the core points' class codes, from the tile's box widened by round-off (core points are
    # decided by a floor of the same coordinates, which can put a point an ulp outside the box)
    x0, y0, x1, y1 = plan.tiling.box(*ij)
    eps = 1e-6 * max(plan.tiling.size, 1.0)
    _, ids, labels = plan.load((x0 - eps, y0 - eps, x1 + eps, y1 + eps))
    mine = np.isin(ids, r.ids)
    if int(mine.sum()) != len(r.ids):
        raise RuntimeError(f"{tile_name(*ij)}: {len(r.ids) - int(mine.sum())} core points not found again "
                           "for their class codes")
    codes = np.empty(len(r.ids), np.int64)
    codes[_positions(r.ids, ids[mine])] = labels[mine]
    sig = Signature.from_saliency(r.values, plan.classes.index(codes), classes=plan.classes,
                                  frame=plan.pipeline.frame)
    flat = sig.counts.ravel()
    nz = np.flatnonzero(flat)
    stats = {**r.stats, "n_undefined": sig.n_undefined, "seconds": time.perf_counter() - t0,
             "sources": sorted(int(s) for s in np.unique(source_of(r.ids))), "resumed": False}
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.stem}.{os.getpid()}.tmp.npz")
    np.savez(tmp, ids=r.ids, values=r.values,
             chosen=r.chosen if r.chosen is not None else np.empty(0, np.int64),
             counts_at=nz, counts=flat[nz], egeom_counts=sig.egeom_counts, class_totals=sig.class_totals,
             key=np.array(key), stats=np.array(json.dumps(stats)))
    os.replace(tmp, path)  # a tile's result exists whole or not at all
    return stats


@dataclass
class SetRun:
    """What a tiled run of a set made, and what it could not."""

    sources: list
    ctx: SetContext | None = None
    tiling: Tiling | None = None
    plan: Plan | None = None
    signature: Signature | None = None
    tile_stats: dict = field(default_factory=dict)
    failed_sources: dict = field(default_factory=dict)
    failed_tiles: dict = field(default_factory=dict)
    sha256: dict = field(default_factory=dict)
    seconds: float = 0.0
    execution: str = ""

    @property
    def missing(self):
        """Lines naming what is missing and why (empty when the run is complete)."""
        lines = [f"{Path(p).name}: {why}" for p, why in self.failed_sources.items()]
        lines += [f"{name}: {why}" for name, why in self.failed_tiles.items()]
        return lines

    @property
    def complete(self):
        return not self.failed_sources and not self.failed_tiles

    def tiling_record(self):
        """The tiling as recorded in the set's archive."""
        return {"tile_size_m": self.tiling.size, "tiles": list(self.tiling.shape), "origin_m": list(self.ctx.lo),
                "centre": list(self.ctx.centre), "area_cap_m": self.ctx.area_cap,
                "n_tiles_run": len(self.tile_stats),
                "n_recomputed": sum(s["n_recomputed"] for s in self.tile_stats.values())}

    def source_records(self):
        """Every source file with its SHA-256 (those that could be read)."""
        return [{"path": s.path, "sha256": self.sha256[s.path]} for s in self.sources if s.path in self.sha256]

    def values_file(self, source):
        """A file of ``source``'s per-point (Cl, Cs, Cp) and chosen scale index (records of
        POINT_VALUES, in its point order), gathered from the tile results one tile at a time;
        None when a tile holding some of its points failed."""
        path = Path(self.plan.work) / "points" / f"s{source.id}.bin"
        path.parent.mkdir(parents=True, exist_ok=True)
        with open(path, "wb") as fh:
            fh.truncate(source.n_points * POINT_VALUES.itemsize)
        found = 0
        for ij, stats in self.tile_stats.items():
            if source.id not in stats["sources"]:
                continue
            with np.load(result_path(self.plan.work, ij)) as r:
                mine = source_of(r["ids"]) == source.id
                at = index_of(r["ids"][mine])
                # mapped per tile and closed again, so that resident memory stays one tile's
                out = np.memmap(path, POINT_VALUES, "r+", shape=(source.n_points,))
                out["values"][at] = r["values"][mine]
                out["chosen"][at] = r["chosen"][mine] if len(r["chosen"]) else -1
                out.flush()
                del out
                found += int(mine.sum())
        return path if found == source.n_points else None

    def saliency_chunks(self, path, has_chosen):
        """``(start, stop) -> Saliency`` of points [start, stop) of a :meth:`values_file`."""
        def chunk(start, stop):
            rec = np.fromfile(path, POINT_VALUES, count=stop - start, offset=start * POINT_VALUES.itemsize)
            return Saliency.from_values(rec["values"], rec["chosen"] if has_chosen else None)
        return chunk

    def saliency_of(self, source):
        """Saliency of one input file's points, in its point order (in memory); None when a
        tile holding some of them failed."""
        path = self.values_file(source)
        if path is None:
            return None
        return self.saliency_chunks(path, self.plan.pipeline.strategy.name == "optimal")(0, source.n_points)

    def write_points(self, source, output, *, overwrite=False):
        """Write ``source`` with its per-point saliency to the LAS/LAZ ``output``, streamed in
        chunks; False (nothing written) when a tile holding some of its points failed."""
        from ..io.las import write_las_chunks

        path = self.values_file(source)
        if path is None:
            return False
        pipe = self.plan.pipeline
        write_las_chunks(output, source.path, self.saliency_chunks(path, pipe.strategy.name == "optimal"),
                         scale_kind=pipe.scales.kind, scale_values=pipe.scales.values, overwrite=overwrite)
        path.unlink()
        return True


def run_set(pipeline, inputs, *, work, tile_size=None, backend=None, resume=False, progress_enabled=None,
            outputs=()):
    """Process the LAS/LAZ files and folders ``inputs`` as one set, in tiles of ``tile_size``
    metres (default: about TILE_POINTS points each), on ``backend``
    (:func:`lidar_sig.tiling.execute.executor`; default this process), with scratch files in
    ``work``, a folder that must not hold an input or one of the ``outputs``. The results stay
    in ``work`` (the :class:`SetRun` reads them from there); the command line removes it after a
    complete run, in Python :func:`remove_work` does. With ``resume``, staged files and finished
    tiles of an earlier run of the same set, grid and method are reused. Returns a
    :class:`SetRun`."""
    from .execute import InProcess

    check_tileable(pipeline)
    if tile_size is not None:
        tile_size = check_tile_size(tile_size)
    as_path(work, "run_set's work (a folder for the run's scratch files)")
    if isinstance(inputs, (str, os.PathLike)):
        inputs = [inputs]
    if not inputs:
        raise LidarSigError("give at least one LAS/LAZ file or folder")
    start = time.perf_counter()
    backend = backend or InProcess()
    files = expand(inputs)
    sources = scan(files)  # bad inputs are refused before anything is written
    good = [s for s in sources if s.error is None]
    if good:
        factors = good[0].factors
        lo = np.min([s.lo for s in good], axis=0)
        hi = np.max([s.hi for s in good], axis=0)
        extent = (hi[:2] - lo[:2]) * np.asarray(factors[:2])  # metres
        area = max(float(np.prod(extent)), 1e-12)
        n_points = sum(s.n_points for s in good)
        if tile_size is None:  # from the headers: about TILE_POINTS per tile, 2 tiles per worker at least
            tile_size = min(tile_side_for(TILE_POINTS, n_points / area),
                            tile_side_for(n_points / (2 * backend.workers), n_points / area))
        n_tiles = math.prod(max(1, math.ceil(e / tile_size)) for e in extent)
        if n_tiles > max(4, n_points / MIN_TILE_POINTS):  # halos would outweigh the tiles' own points
            raise LidarSigError(f"tiles of {tile_size:g} m would hold about {n_points / n_tiles:,.0f} points "
                                f"each ({n_tiles:,} tiles); give a --tile-size of at least "
                                f"{tile_side_for(MIN_TILE_POINTS, n_points / area):.3g} m, or none for the "
                                "default")
    work = prepare_work(work, resume, keep=[*files, *outputs])
    run = SetRun(sources, execution=backend.description)
    for s in sources:
        if s.error:
            run.failed_sources[s.path] = s.error
    if not good:
        return run
    cells = Cells(tuple(lo[:2].tolist()), float(tile_size) / factors[0] / CELLS_PER_TILE)

    # 1. staging
    records = {}
    todo = []
    for s in good:
        for part, (first, stop) in enumerate(s.parts(backend.workers)):
            info = staged(work, s, part, first, stop, cells) if resume else None
            if info is None:
                todo.append((str(work), s, part, first, stop, cells))
            else:
                records[(s.id, part)] = info
    for (_, s, part, *_), info, err in progress(backend.run(stage_task, todo), total=len(todo),
                                               desc="reading", enabled=progress_enabled, unit="part"):
        if err is None:
            records[(s.id, part)] = info
        else:
            run.failed_sources.setdefault(s.path, _reason(err))
    staged_ok = [s for s in good if s.path not in run.failed_sources]
    records = {k: v for k, v in records.items() if sources[k[0]].path not in run.failed_sources}
    for (sid, part), info in records.items():
        if part == 0:
            run.sha256[info["path"]] = info["sha256"]
    if not staged_ok:
        return run

    # 2. the set's context
    lo = np.min([r["lo"] for r in records.values()], axis=0)
    hi = np.max([r["hi"] for r in records.values()], axis=0)
    n_points = sum(r["n"] for r in records.values())
    need = pipeline.min_points()
    if n_points < need:
        raise LidarSigError(f"the set holds {n_points} points, fewer than the largest scale needs ({need}); "
                            "use a larger set or smaller scales")
    ctx = context_of(lo, hi, factors, pipeline, n_points)
    tiling = Tiling(ctx.lo, ctx.hi, float(tile_size))
    labelled = any(r["labelled"] for r in records.values())
    pipe = _quiet(pipeline)
    staged_key = json.dumps(sorted([r["path"], r["identity"], r["n"], part] for (_, part), r in records.items()))
    plan = Plan(str(work), pipe, ctx, tiling, cells, cell_files(work, records),
                pipeline.classes if labelled else UNLABELED, staged_key)
    tiles = [ij for ij in tiling.tiles() if _occupied(plan, ij)]
    if pipeline.weights == "area":
        cap = _cached_cap(work, plan, resume)
        if cap is None:
            dist = []
            for (_, ij), d, err in progress(backend.run(second_task, [(plan, ij) for ij in tiles]),
                                            total=len(tiles), desc="area weights", enabled=progress_enabled,
                                            unit="tile"):
                if err is not None:
                    run.failed_tiles[tile_name(*ij)] = _reason(err)
                dist.append(d if err is None else np.empty(0))
            if run.failed_tiles:
                return run
            cap = area_cap(np.concatenate(dist))
            (work / "area_cap.json").write_text(json.dumps({"key": plan.key(), "cap": cap}))
        ctx = SetContext(ctx.centre, ctx.factors, ctx.lo, ctx.hi, ctx.scales, cap, ctx.density)
        plan = Plan(plan.work, plan.pipeline, ctx, plan.tiling, plan.cells, plan.files, plan.classes, plan.staged)
    run.ctx, run.tiling, run.plan = ctx, tiling, plan

    # 3. tiles
    bar = progress(backend.run(tile_task, [(plan, ij) for ij in tiles]), total=len(tiles), desc="tiles",
                   enabled=progress_enabled, unit="tile")
    points = 0
    for (_, ij), stats, err in bar:
        if err is not None:
            run.failed_tiles[tile_name(*ij)] = _reason(err)
            continue
        run.tile_stats[ij] = stats
        points += stats["n_points"]
        bar.set_postfix_str(f"{points / max(time.perf_counter() - start, 1e-9):,.0f} points/s")

    # 4. reduce
    if run.complete:
        run.signature = _sum_signatures(run)
    run.seconds = time.perf_counter() - start
    return run


#: File that marks a folder as a work folder of ours (only such a folder is ever removed).
WORK_MARK = "LIDAR_SIG_WORK"


def prepare_work(work, resume, keep=()):
    """The work folder, made (or emptied, without ``resume``); refuses a folder that holds
    anything but an earlier run's work, or that is or holds one of the paths ``keep`` (inputs and
    outputs: the folder is removed after a complete run)."""
    work = Path(work).resolve()
    for p in keep:
        p = Path(p).resolve()
        if p == work or work in p.parents:
            raise LidarSigError(f"would hold {p}, but the work folder is removed after the run; give "
                                "--work-dir a folder of its own", path=work)
    if work.exists() and any(work.iterdir()) and not (work / WORK_MARK).is_file():
        raise LidarSigError("is not empty and not a lidar_sig work folder; give a new or empty folder as "
                            "--work-dir", path=work)
    if work.exists() and not resume:
        shutil.rmtree(work)
    work.mkdir(parents=True, exist_ok=True)
    (work / WORK_MARK).write_text("scratch files of a tiled lidar_sig run; safe to delete\n")
    return work


def remove_work(work):
    """Remove a work folder of ours (after a complete run)."""
    if (Path(work) / WORK_MARK).is_file():
        shutil.rmtree(work, ignore_errors=True)


def _sum_signatures(run):
    plan = run.plan
    counts = None
    egeom = totals = None
    n_undefined = 0
    for ij in run.tile_stats:
        with np.load(result_path(plan.work, ij)) as r:
            if counts is None:
                shape = (len(plan.classes), plan.pipeline.frame.size, plan.pipeline.frame.size)
                counts = np.zeros(int(np.prod(shape)), np.int64)
                egeom, totals = np.zeros_like(r["egeom_counts"]), np.zeros_like(r["class_totals"])
            counts[r["counts_at"]] += r["counts"]
            egeom += r["egeom_counts"]
            totals += r["class_totals"]
        n_undefined += run.tile_stats[ij]["n_undefined"]
    stats = {k: sum(s[k] for s in run.tile_stats.values()) for k in ("n_points", "n_locations", "n_capped")}
    pipe = plan.pipeline
    metadata = {"lidar_sig_version": __version__, "source": ", ".join(s.name for s in run.sources),
                "scales": pipe.scales.describe(), "crs": next((s.crs for s in run.sources if s.crs), None),
                "n_points": stats["n_points"], "n_undefined": n_undefined, "n_capped": stats["n_capped"],
                "n_duplicates": stats["n_points"] - stats["n_locations"],
                "resolved_scales": list(run.ctx.scales), "units": next(s.units for s in run.sources if s.error is None),
                "metres_per_unit": list(run.ctx.factors), **pipe.method()}
    return Signature(counts.reshape(shape), pipe.frame, plan.classes, egeom, n_undefined, metadata, totals)


def _cached_cap(work, plan, resume):
    path = Path(work) / "area_cap.json"
    if resume and path.is_file():
        saved = json.loads(path.read_text())
        if saved.get("key") == plan.key():
            return float(saved["cap"])
    return None


def _occupied(plan, ij):
    # a tile whose box meets no staged cell has no core points
    x0, y0, x1, y1 = plan.tiling.box(*ij)
    c, f = plan.ctx.centre, plan.ctx.factors
    raw = (x0 / f[0] + c[0], y0 / f[1] + c[1], x1 / f[0] + c[0], y1 / f[1] + c[1])
    return any(key in plan.files for key in plan.cells.covering(raw))


def _quiet(pipeline):
    import copy

    pipe = copy.copy(pipeline)
    pipe.progress = False  # workers show nothing; the main process shows tiles done
    return pipe


def _reason(err):
    if isinstance(err, LidarSigError):  # the file is named where the reason is printed
        text = str(err)
        return text[len(err.path) + 2:] if err.path and text.startswith(err.path) else text
    return f"{type(err).__name__}: {err}"
