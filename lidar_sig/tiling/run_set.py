"""A set of LAS/LAZ files processed in tiles: staging, the set's context, tiles, reduce.

1. **Staging**: each file is read once, in chunks, and its points filed by plan-view cell in the
   work folder (:mod:`lidar_sig.tiling.sources`); one task per file part. Withheld and noise
   points are counted and left out here (unless ``keep_noise``), as in the single-block run.
2. **Context**: the set's extent, scales and (with area weights) the area-weight cap, from a
   pass of small tasks over the tiles (:class:`lidar_sig.tiling._core.SetContext`).
3. **Tiles**: one task per processing tile computes its core points' saliency with a checked
   halo and the tile's signature, and writes them to the work folder (each file complete or
   absent, so ``resume`` can skip finished tiles).
4. **Reduce**: the set's signature is the sum of the tiles' (count rasters are additive);
   per-point outputs are gathered per input file.

A file that cannot be read and a tile that fails are recorded by name; the others go on. The
results are then those of the set without the missing file, and the set's signature is not
made: :attr:`~lidar_sig.tiling._set_run.SetRun.missing` says what is missing.

This module orchestrates; the tasks are in :mod:`~lidar_sig.tiling._tasks`, what a run made in
:mod:`~lidar_sig.tiling._set_run`, the work folder in :mod:`~lidar_sig.tiling.work`.
"""
from __future__ import annotations

import json
import math
import os
import time
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from ..method.classes import UNLABELED
from ..base.errors import LidarSigError, arg, as_path, counted
from ..numerics.neighbors import AREA_CAP, cap_share, sampled_area_cap
from ..base.progress import progress, step
from ._core import SetContext, Tiling, check_tile_size, check_tileable, context_of, tile_name
from ._median import sorted_median
from .memory import DEFAULT_MEMORY, budget_bytes, tile_points
from ._set_run import SetRun, TiledResult, sum_signatures
from .sources import Cells, cell_files, densest, expand, scan, staged, tile_side_for
from ._tasks import Plan, cap_task, second_paths, second_task, stage_task, tile_task
from .work import (discard_work, forget_area_cap, fresh_work, prepare_work, remove_work, save_area_cap,
                   saved_area_cap, work_scope)

#: Staging cells per tile side.
CELLS_PER_TILE = 4
#: Fewest points a processing tile holds on average: smaller tiles are refused.
MIN_TILE_POINTS = 500


def run_set(pipeline: Any, inputs: Any, *, work: str | os.PathLike[str], tile_size: float | None = None,
            backend: Any = None, resume: bool = False, progress_enabled: bool | None = None, outputs: Any = (),
            memory: int | str = DEFAULT_MEMORY, sample: Any = None) -> SetRun:
    """Process the LAS/LAZ files and folders ``inputs`` as one set, in tiles of ``tile_size``
    metres (default: as many points as a process holds within ``memory`` bytes,
    :func:`lidar_sig.tiling.memory.tile_points`, and two tiles per worker at least), on ``backend``
    (:func:`lidar_sig.tiling.backends.executor`; default this process), with scratch files in
    ``work``, a folder that must not hold an input or one of the ``outputs``. The results stay
    in ``work`` (the :class:`SetRun` reads them from there); the command line removes it after a
    complete run, in Python :func:`lidar_sig.tiling.work.remove_work` does. With ``resume``, staged files and finished
    tiles of an earlier run of the same set, grid and method are reused. Returns a
    :class:`SetRun`. ``sample(run, tiles)``, when given, is called once the set is staged and
    tiled (``run.plan`` set, ``tiles`` the occupied ones) and returns the points whose saliency is
    computed (an object with ``mask(raw xyz, class codes) -> (N,) bool``, kept on the
    :class:`Plan`), or None for every point: a change map computes its cells' sample alone.

    The work folder is held by this run (another run is refused) until it returns or raises,
    or until its job ends (:func:`lidar_sig.tiling.work.work_scope`); then it is let go, and
    kept only when it holds what a resumed run reuses."""
    as_path(work, "run_set's work (a folder for the run's scratch files)")
    with work_scope(work):
        return _run_set(pipeline, inputs, work=work, tile_size=tile_size, backend=backend, resume=resume,
                        progress_enabled=progress_enabled, outputs=outputs, memory=memory, sample=sample)


def _run_set(pipeline, inputs, *, work, tile_size, backend, resume, progress_enabled, outputs, memory, sample=None):
    """:func:`run_set` within the scope of its work folder."""
    from .backends import InProcess

    check_tileable(pipeline)
    memory = budget_bytes(memory)
    pipeline.announce_compilation()  # the workers compile in silence (their pipelines are quiet)
    sized = tile_size is None  # sized to the memory budget
    if not sized:
        tile_size = check_tile_size(tile_size)
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
        tile_size = header_tile_size(good, None if sized else tile_size, memory, backend.workers)
    work = prepare_work(work, resume, keep=[*files, *outputs])
    run = SetRun(sources, execution=backend.description)
    for s in sources:
        if s.error:
            run.failed_sources[s.path] = s.error
    if not good:
        return run
    cells = Cells(tuple(lo[:2].tolist()), float(tile_size) / factors[0] / CELLS_PER_TILE)

    # 1. staging
    records = run.records = _stage(work, good, sources, cells, run, backend, resume, pipeline.noise_codes(),
                                   progress_enabled)
    if not any(s.path not in run.failed_sources for s in good):
        return run

    # 2. the set's context, from the points staged (withheld and noise points left out)
    lo = np.min([r["lo"] for r in records.values()], axis=0)
    hi = np.max([r["hi"] for r in records.values()], axis=0)
    n_points = _enough_points(pipeline, records, run)
    ctx = context_of(lo, hi, factors, pipeline, n_points)
    if sized:  # the headers' mean density can hide a denser part: no tile may hold more than the budget
        tile_size = min(tile_size, tile_side_for(tile_points(memory), densest(records, cells, factors)))
    tiling = Tiling(ctx.lo, ctx.hi, float(tile_size))
    labelled = run.labelled = any(r["labelled"] for r in records.values())
    pipe = _quiet(pipeline)
    staged_key = json.dumps(sorted([r["path"], r["identity"], r["n"], part] for (_, part), r in records.items()))
    plan = Plan(str(work), pipe, ctx, tiling, cells, cell_files(work, records),
                pipeline.classes if labelled else UNLABELED, staged_key)
    tiles = [ij for ij in tiling.tiles() if plan.occupied(ij)]
    if sample is not None:
        run.ctx, run.tiling, run.plan = ctx, tiling, plan
        plan = replace(plan, sample=sample(run, tiles))
    if pipeline.weights.by_area:
        plan = _with_area_cap(plan, tiles, work, run, backend, resume, progress_enabled, n_points)
        if plan is None:
            return run
        ctx = plan.ctx
    run.ctx, run.tiling, run.plan = ctx, tiling, plan

    # 3. tiles
    _tiles(plan, tiles, run, backend, progress_enabled, start)

    # 4. reduce
    if run.complete:
        with step("signature of the set", enabled=False):
            run.signature = sum_signatures(run)
    run.seconds = time.perf_counter() - start
    if resume:
        resumed_note(work, [f"{run.reused_parts} of {counted(len(records), 'staged part')}",
                            f"{sum(bool(t.get('resumed')) for t in run.tile_stats.values())} of "
                            f"{counted(len(tiles), 'tile')}"], run.restaged)
    return run


def resumed_note(work, reused, recomputed=()):
    """Say, as a note, what a resumed run reused from the work folder ``work`` (``reused``: "3 of
    4 tiles", ...) and what it recomputed besides what was left to do: ``recomputed`` and the
    damaged files it found there (:func:`~lidar_sig.tiling.work.damaged`)."""
    import warnings

    from ..base.errors import LidarSigWarning
    from .work import damaged

    found = damaged(work)
    if not found and not recomputed and all(r.startswith("0 of") for r in reused):
        return  # nothing was there: the work folder's own note said so
    again = list(recomputed) + ([f"{counted(len(found), 'damaged file')} ({Path(found[0]).name}"
                                 + (", ..." if len(found) > 1 else "") + ")"] if found else [])
    warnings.warn(f"resumed from {work}: reused {', '.join(reused)}"
                  + (f"; recomputed {', '.join(again)}" if again else ""), LidarSigWarning, stacklevel=2)


def header_tile_size(good, tile_size, memory, workers, *, advise=None):
    """The tile side (metres) from the files' headers: ``tile_size`` when given (refused when its
    tiles would hold fewer than :data:`MIN_TILE_POINTS` points each, advising
    :func:`least_tile_size`, or ``advise`` where several sets must pass), else a tile's block
    within the budget ``memory`` and two tiles per worker at least (if not too small)."""
    n_points, extent, area = _header_extent(good)
    least = tile_side_for(MIN_TILE_POINTS, n_points / area)  # smaller tiles: the halos would be most of the work
    if tile_size is None:
        return min(tile_side_for(tile_points(memory), n_points / area),
                   max(tile_side_for(n_points / (2 * workers), n_points / area), least))
    n_tiles, most = _tile_count(extent), max(4, n_points / MIN_TILE_POINTS)
    if n_tiles(tile_size) > most:
        raise LidarSigError(f"{arg('tile_size', tile_size)} is too small for these files: its tiles would hold "
                            f"about {n_points / n_tiles(tile_size):,.0f} points each, fewer than {MIN_TILE_POINTS}; "
                            f"give at least {advise or least_tile_size(good):.3g} m, or leave it out for the default")
    return tile_size


def least_tile_size(good):
    """The smallest tile side (metres), rounded up to three significant digits, that
    :func:`header_tile_size` takes for the files ``good``: the advice names a value that passes."""
    n_points, extent, _ = _header_extent(good)
    n_tiles, most = _tile_count(extent), max(4, n_points / MIN_TILE_POINTS)
    low, high = 0.0, max(float(max(extent)), 1e-9)  # a side of the longest extent: one tile across
    for _ in range(100):  # bisection: the count falls as the side grows, in steps at e / k
        mid = (low + high) / 2
        low, high = (low, mid) if n_tiles(mid) <= most else (mid, high)
    digits = 2 - math.floor(math.log10(high))
    side = math.ceil(high * 10 ** digits) / 10 ** digits  # rounded up: still passes
    return side if n_tiles(side) <= most else high


def _header_extent(good):
    """(points, extent (2,) in metres, area in m²) of the files ``good`` from their headers."""
    factors = good[0].factors
    lo = np.min([s.lo for s in good], axis=0)
    hi = np.max([s.hi for s in good], axis=0)
    extent = (hi[:2] - lo[:2]) * np.asarray(factors[:2])  # metres
    return sum(s.n_points for s in good), extent, max(float(np.prod(extent)), 1e-12)


def _tile_count(extent):
    """The number of tiles of a side (metres) over ``extent``."""
    return lambda side: math.prod(max(1, math.ceil(e / side)) for e in extent)


def _enough_points(pipeline, records, run):
    """The points the set staged and kept (withheld and noise points left out), refused when
    fewer than the method's largest scale needs."""
    n_points = sum(r["n"] - r["n_excluded"] for r in records.values())
    need = pipeline.min_points()
    if n_points < need:
        left_out = sum(run.excluded.values())
        raise LidarSigError(f"the set holds {counted(n_points, 'point')}"
                            + (f" besides {counted(left_out, 'withheld or noise point')}" if left_out else "")
                            + f", fewer than the largest scale needs ({need}); use a larger set or smaller scales"
                            + (f" ({arg('keep_noise', True)} uses every point)" if left_out else ""))
    return n_points


def _tiles(plan, tiles, run, backend, progress_enabled, start):
    """Run the ``tiles`` of ``plan``, their statistics (or why they failed) recorded in ``run``."""
    bar = progress(backend.run(tile_task, [(plan, ij) for ij in tiles]), total=len(tiles), desc="tiles",
                   enabled=progress_enabled, unit="tile")
    points = 0
    with step("tiles", enabled=False, tiles=len(tiles), tile_size=f"{plan.tiling.size:.4g} m") as st:
        for (_, ij), stats, err in bar:
            if err is not None:
                run.failed_tiles[tile_name(*ij)] = _reason(err)
                continue
            run.tile_stats[ij] = stats
            points += stats["n_points"]
            bar.set_postfix_str(f"{points / max(time.perf_counter() - start, 1e-9):,.0f} points/s")
        st.note(points=points, recomputed=sum(s["n_recomputed"] for s in run.tile_stats.values()))


def _stage(work, good, sources, cells, run, backend, resume, noise_codes, progress_enabled):
    """Stage every part of the readable files ``good`` (reusing what a resumed run finished);
    {(source, part): record} of those staged, the files that failed recorded in ``run``."""
    from ..io.archive import sha256_of

    records = {}
    todo = []
    for s in good:
        parts = s.parts(backend.workers)
        found = [staged(work, s, part, first, stop, cells, noise_codes) if resume else (None, None)
                 for part, (first, stop) in enumerate(parts)]
        infos = [info for info, _ in found]
        why = [reason for _, reason in found if reason]
        if any(infos) and infos[0] is None:  # the first part holds the file's SHA-256: none to check the others by
            infos = [None] * len(parts)
            why = why or ["its first part unfinished: an interrupted staging"]
        elif infos[0] is not None and infos[0].get("sha256") != sha256_of(s.path):
            # a file edited in place keeps its size and time: its content is what tells
            infos = [None] * len(parts)
            why = ["edited since"]
        if why:
            run.restaged.append(f"{s.name} ({why[0]})")
        for part, ((first, stop), info) in enumerate(zip(parts, infos)):
            if info is None:
                todo.append((str(work), s, part, first, stop, cells, noise_codes))
            else:
                records[(s.id, part)] = info
                run.reused_parts += 1
    with step("staging", enabled=False, parts=len(todo)) as st:  # --verbose: each stage's time
        for (_, s, part, *_), info, err in progress(backend.run(stage_task, todo), total=len(todo),
                                                   desc="reading", enabled=progress_enabled, unit="part"):
            if err is None:
                records[(s.id, part)] = info
            else:
                run.failed_sources.setdefault(s.path, _reason(err))
        st.note(points=sum(r["n"] for r in records.values()))
    records = {k: v for k, v in records.items() if sources[k[0]].path not in run.failed_sources}
    for (sid, part), info in records.items():
        if part == 0:
            run.sha256[info["path"]] = info["sha256"]
        run.excluded[sid] = run.excluded.get(sid, 0) + info["n_excluded"]
    return records


def _with_area_cap(plan, tiles, work, run, backend, resume, progress_enabled, n_points):
    """``plan`` with the set's area-weight cap in its context: the median second-neighbour
    distance over every distinct location of a set of ``n_points`` points, or over a sample of
    windows above a million (:func:`lidar_sig.numerics.neighbors.set_area_cap`), from a pass
    over the tiles (or a resumed run's); None when a tile of that pass failed (recorded in
    ``run``)."""
    share = cap_share(n_points)
    key = cap_key(plan)
    saved = saved_area_cap(work, key) if resume else None
    cap, second_known = saved if saved is not None else (None, True)
    if cap is None:
        forget_area_cap(work)  # the distances it was found from are about to be replaced
        with step("area-weight cap", enabled=False, tiles=len(tiles)) as st:
            if share < 1.0:
                found = _cap_pass(cap_task, [(plan, ij, share) for ij in tiles], run, backend, progress_enabled)
                if found is None:
                    return None
                cap = sampled_area_cap(np.concatenate(found))
                st.note(sample=f"{sum(map(len, found)):,} locations")
            if cap is None:  # every location (or the sample's windows held none)
                if _cap_pass(second_task, [(plan, ij) for ij in tiles], run, backend, progress_enabled) is None:
                    return None
                # the median over every distinct location, from the tiles' sorted files (not in memory)
                cap = AREA_CAP * sorted_median([second_paths(work, ij)[0] for ij in tiles])
            else:
                second_known = False  # each tile searches its own
            st.note(cap=f"{cap:.4g} m")
        save_area_cap(work, key, cap, second_known)
    ctx = plan.ctx
    ctx = SetContext(ctx.centre, ctx.factors, ctx.lo, ctx.hi, ctx.scales, cap, ctx.density)
    return replace(plan, ctx=ctx, second_known=second_known)


def cap_key(plan):
    """What a saved area-weight cap must match to be reused: the plan's key and the rule of the
    cap's sample (a work folder an earlier rule left is not taken at its word)."""
    from ..numerics import neighbors

    return json.dumps([plan.key(), neighbors.CAP_POINTS, neighbors.CAP_WINDOW, neighbors.CAP_REACH])


def _cap_pass(task, items, run, backend, progress_enabled):
    """The results of the cap's ``task`` over ``items`` (one per tile), or None when one failed
    (recorded in ``run``)."""
    found = []
    for (_, ij, *_), result, err in progress(backend.run(task, items), total=len(items), desc="area weights",
                                             enabled=progress_enabled, unit="tile"):
        if err is not None:
            run.failed_tiles[tile_name(*ij)] = _reason(err)
        found.append(result)
    return None if run.failed_tiles else found


def run_in_tiles(pipeline, source, execution, *, n_points, work=None, outputs=()):
    """One LAS/LAZ file whose ``n_points`` points one block would hold above the memory budget
    of ``execution``, processed in tiles (:func:`run_set`) into a
    :class:`~lidar_sig.tiling._set_run.TiledResult`, which keeps the per-point values in the
    work folder: ``work`` (a job's, beside its output), else a new folder of its own in the
    execution's ``work_dir`` or the temporary folder (a result kept in Python: two results never
    share one). The folder goes with the result (:meth:`TiledResult.close`), or at once when the
    run fails or lacks a point (LidarSigError naming what is missing)."""
    ours = work is None
    work = fresh_work(execution.work_dir) if ours else Path(work)
    remove = discard_work if ours else remove_work
    try:
        with execution.backend() as backend:
            run = run_set(pipeline, [source], work=work, tile_size=execution.tile_size, backend=backend,
                          outputs=outputs, memory=execution.memory)
        if not run.complete:
            shown = run.missing[:3] + ([f"and {len(run.missing) - 3} more"] if len(run.missing) > 3 else [])
            raise LidarSigError("could not be processed in tiles: " + "; ".join(shown), path=source)
    except BaseException:
        remove(work)
        raise
    return TiledResult(run, work, n_points, execution.memory, remove)


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
