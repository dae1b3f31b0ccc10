"""The change map of two epochs at survey scale, in work units within the memory budget
(docs/changes.md, "At survey scale"): each epoch's saliency as a tiled run of its files
(:func:`lidar_sig.tiling.run_set.run_set`, halos checked per point), then the tasks of
:mod:`~lidar_sig.change_map._units` on the same backend (this process, local processes or a Dask
cluster), then the survey part of the level of detection over every cell, the ranking and the
same :class:`~lidar_sig.change_map.ChangeMap` as one block gives. Its epochs are
:class:`TiledEpoch`: their points stay in the work folder, read again for a cell's signature,
the report's top view and the per-point change, streamed."""
from __future__ import annotations

import math
import os
import warnings
import time
import weakref
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import numpy as np

from ..base.errors import FACE, LidarSigError, LidarSigWarning, counted
from ..base.progress import progress, step
from ..method.classes import UNLABELED
from ..method.signature_raster import Signature
from ._cells import CHANGE_KEYS, Sample, counts_table
from ._lod import few_cells_note
from ._density import auto_cell, auto_min_points, no_defined_cell, sample_fraction, sparse_note
from ._grid import Grid, check_cells, check_overlap, check_span
from ._units import (UNIT_BYTES_PER_POINT, VIEW_POINTS, UnitPlan, code_task, density_pixel, density_task,
                     unit_points, unit_task, view_path)

#: Bytes a change map computed in one block holds per point of both epochs (the clouds, their
#: saliency, the binned codes; docs/changes.md, "Memory"), above the base of a process
#: (:data:`lidar_sig.tiling.memory.BASE_BYTES`): above the memory budget, the map is made in
#: work units.
ONE_BLOCK_BYTES_PER_POINT = 330
#: Work units per worker at least, so that every worker has work while the last ones finish.
UNITS_PER_WORKER = 2


def epoch_files(source):
    """The LAS/LAZ files of an epoch given as a file, folder, list, glob pattern or ``.vpc``
    (in the order in which one block joins them), or None when it is anything else."""

    from ..tiling.sources import NotLasSet, expand

    if isinstance(source, (str, os.PathLike)):
        given = [source]
    elif isinstance(source, (list, tuple)) and source and all(isinstance(p, (str, os.PathLike)) for p in source):
        given = list(source)
    else:
        return None
    try:
        return expand(given)
    except NotLasSet:  # other formats: one block reads them (a refusal of the set itself is the user's)
        return None


def in_units(sources: list[Any], execution: Any, pipeline: Any, resume: bool = False) -> list[list[Path]] | None:
    """The LAS/LAZ files of each of two epochs when their change map runs in work units: a
    tile size, workers, a scheduler or ``resume`` asked for it (as they ask a set's saliency to
    run in tiles), or one block of both epochs would need more than the memory budget (then
    with a descriptor that runs in tiles; another runs as one block, with a note); else None."""
    from ..tiling.memory import BASE_BYTES, header_points, one_block_note

    if len(sources) != 2:
        return None
    files = [epoch_files(s) for s in sources]
    if any(f is None for f in files):
        return None
    if execution.tiles_asked or resume:
        return files
    try:
        n = sum(header_points(p) or 0 for f in files for p in f)
    except Exception:  # a damaged header: one block reads it and says why
        return None
    if BASE_BYTES + n * ONE_BLOCK_BYTES_PER_POINT <= int(execution.memory):  # the process's own memory too
        return None
    if not pipeline.descriptor.tileable:
        warnings.warn(one_block_note(f"{sources[0]} and {sources[1]}", n, int(execution.memory),
                                     pipeline.descriptor.name), LidarSigWarning, stacklevel=3)
        return None
    return files


class TiledEpoch:
    """An epoch of a change map made in work units: its name, its tiled saliency run (a
    :class:`~lidar_sig.tiling._set_run.SetRun`), its method, and its coded points in the work
    folder, read again for a cell's signature, the top view and the per-point change."""

    def __init__(self, name, run, uplan, index, tiles_of, metadata, holder):
        self.name, self.run, self.metadata = name, run, metadata
        self._uplan, self._index, self._tiles_of, self._holder = uplan, index, tiles_of, holder

    def __repr__(self):
        return f"<TiledEpoch {self.name}: {counted(self.n_points, 'point')} in {Path(self._uplan.work)}>"

    @property
    def n_points(self):
        return sum(s.n_points for s in self.run.sources)

    def close(self):
        """Remove the work folder (the map's per-cell values remain)."""
        self._holder.close()

    def cell_signature(self, flat, grid, classes, labelled, frame):
        """The signature of cell ``flat``, from its work unit's coded points."""
        self._holder.check()
        unit = int(self._uplan.unit_of([flat])[0])
        rec = unit_points(self._uplan, self._index, unit, self._tiles_of.get(unit, []))
        rec = rec[rec["cell"] == flat]
        return Signature.from_codes(rec["pixel"], rec["egeom"], rec["cls"], classes=classes, frame=frame)

    def view(self):
        """(coordinates (N, 3), saliency (N, 3)) of a thinned sample of the points (about
        :data:`~lidar_sig.change_map._units.VIEW_POINTS`): the report's top view."""
        self._holder.check()
        parts = [np.load(view_path(self._uplan.work, self._index, ij)) for ij in self.run.tile_stats]
        rec = np.concatenate(parts)
        return np.column_stack([rec["x"], rec["y"], rec["z"]]), rec["values"]

    def write_points(self, path, extra, *, overwrite=False):
        """Stream the epoch's file with its saliency and the fields ``extra(xy)`` to the LAS/LAZ
        ``path``, chunk by chunk (one file: a map of several tiles writes none)."""
        from ..io.las import write_las_chunks

        self._holder.check()
        check_streamed(path, len(self.run.sources), self.name)
        source = self.run.sources[0]
        pipe = self.run.plan.pipeline
        write_las_chunks(path, source.path, self.run.point_values(source), scale_kind=pipe.scales.kind,
                         scale_values=pipe.scales.values, overwrite=overwrite, extra=lambda xyz: extra(xyz[:, :2]))


class WorkHolder:
    """The work folder of a change map made in work units, kept while its map is used: removed
    by :meth:`close`, after which the map's per-cell values stay and what reads its points
    refuses. A folder made for the map alone (``own``, in the temporary folder) also goes when
    the map is collected; one that was given stays until :meth:`close` (a job closes it once its
    outputs are written, and keeps it after an interruption for a resumed run)."""

    def __init__(self, work, remove, own=False):
        self.work = Path(work)
        self._remove, self._open = remove, True
        self._finalizer = weakref.finalize(self, remove, self.work) if own else None

    def check(self):
        if not self._open:
            raise LidarSigError("the change map's work folder was removed (close()); its per-cell values remain, "
                                "its points do not: compute the map again to read them", path=self.work)

    def close(self):
        if self._open:
            self._open = False
            if self._finalizer is not None:
                self._finalizer()
            else:
                self._remove(self.work)


def staged_bounds(run):
    """(lo (3,), hi (3,), points, records) of the points an epoch's tiled run staged and kept,
    exactly, in the files' coordinates, and its staged parts' records they come from."""
    records = list(run.records.values())  # those of this run (a resumed folder may hold others)
    lo = np.min([r["lo"] for r in records], axis=0)
    hi = np.max([r["hi"] for r in records], axis=0)
    return lo, hi, sum(r["n"] - r["n_excluded"] for r in records), records


def changes_in_units(files, names, *, pipeline, execution, work, resume, settings, classes_table, remove, own=False):
    """The :class:`~lidar_sig.change_map.ChangeMap` of two epochs' LAS/LAZ ``files`` in work
    units, with scratch files in ``work`` (``remove(work)`` removes it with the map's
    :class:`WorkHolder`; ``own``: a folder made for this map alone); ``settings`` are those of
    :func:`~lidar_sig.change_map.changes`, with ``keep``, the outputs the folder must not hold."""
    from ..tiling.sources import scan
    from ..tiling.work import work_scope
    from ._epochs import check_same_crs

    scanned = [[s for s in scan(f) if s.error is None] for f in files]  # before any work
    check_same_crs([SimpleNamespace(crs=next((s.crs for s in good), None)) for good in scanned], names)
    _check_headers(scanned, names, execution, settings)
    try:  # a task that failed inside an epoch's run leaves that run's work for a resumed run
        with work_scope(work):
            return _run(files, names, pipeline, execution, work, resume, settings, classes_table, remove, own)
    except _TaskFailed as failed:
        raise _failed(failed.err, failed.what, work) from None


def _run(files, names, pipeline, execution, work, resume, settings, classes_table, remove, own):
    """:func:`changes_in_units` within the scope of its work folder."""
    from ..tiling.run_set import run_set
    from ..tiling.work import prepare_work

    work = prepare_work(work, resume, keep=[p for f in files for p in f] + list(settings.get("keep", ())))
    with execution.backend() as backend:
        start = time.perf_counter()
        runs, seconds = [], []
        for e, tag in enumerate("ab"):
            t0 = time.perf_counter()
            with step(f"saliency of {names[e]}", files=len(files[e])):
                run = run_set(pipeline, files[e], work=work / f"epoch_{tag}", tile_size=execution.tile_size,
                              backend=backend, resume=resume, memory=execution.memory,
                              sample=lambda run, tiles: _sample(run, tiles, backend, settings["sample_density"]))
            if not run.complete:
                shown = run.missing[:3] + ([f"and {len(run.missing) - 3} more"] if len(run.missing) > 3 else [])
                raise LidarSigError(f"the epoch {names[e]} could not be computed: " + "; ".join(shown))
            runs.append(run)
            seconds.append(time.perf_counter() - t0)
        cm = _map(runs, names, files, pipeline, backend, work, settings, classes_table, WorkHolder(work, remove, own))
        if resume:
            from ..tiling.run_set import resumed_note

            units = cm.timings["units"]
            resumed_note(work, [f"{units['reused']} of {counted(units['units'], 'work unit')}"])
        cm.timings["saliency"] = seconds
        cm.timings["all"] = time.perf_counter() - start
        return cm


def _check_headers(scanned, names, execution, settings):
    """What the epochs' headers (``scanned``: each epoch's readable :class:`Source` files) tell
    before any saliency: epochs that share no land, a given cell size whose grid is too large, a
    tile size too small for either epoch (found then after both saliencies, with a work folder
    kept that no resumed run could finish)."""
    from ..tiling.run_set import header_tile_size, least_tile_size

    if not all(scanned):
        return  # a file that cannot be read is named by its epoch's run
    corners = [np.array([np.min([s.lo for s in good], axis=0)[:2], np.max([s.hi for s in good], axis=0)[:2]])
               for good in scanned]
    check_overlap(*corners, *names)
    if settings.get("cell") is not None:
        check_span(np.vstack(corners), settings["cell"] / scanned[0][0].factors[0], settings["cell"])
    if execution.tile_size is not None:
        least = max(least_tile_size(good) for good in scanned)  # the advice passes for both epochs
        for good in scanned:
            header_tile_size(good, execution.tile_size, execution.memory, execution.workers or 1, advise=least)


def _sample(run, tiles, backend, most):
    """The :class:`~lidar_sig.change_map._cells.Sample` of an epoch's tiled ``run``, staged and
    tiled (``tiles``), from its density (kept as ``run.density``) and the sample's ``most``
    points per m² (None: every point, a fraction of 1): what its tiles compute and keep coded
    for the cells (:func:`lidar_sig.tiling.run_set.run_set`'s ``sample``)."""
    run.density = _densities(run, tiles, backend)
    fraction = sample_fraction(run.density, most)
    run.sampled = run.density * fraction
    return Sample(fraction)


def _frame(runs, names, s):
    """(units, bounds, densities, notes, cell, min_points, grid) of two complete tiled runs: the
    CRS checked, each epoch's staged extent, its density and its sample's, the defaults chosen,
    the map's grid."""
    from ..method.crs import las_units
    import laspy

    with laspy.open(runs[0].sources[0].path) as reader:
        _, units = las_units(reader.header, path=runs[0].sources[0].path)
    bounds = [staged_bounds(run) for run in runs]
    densities = [run.density for run in runs]
    sampled = [run.sampled for run in runs]
    notes = [n for n in [sparse_note(names, densities)] if n]
    cell = auto_cell(min(sampled)) if s.cell is None else s.cell
    min_points = auto_min_points(min(sampled), cell) if s.min_points is None else s.min_points
    corners = [np.array([b[0][:2], b[1][:2]]) for b in bounds]
    check_overlap(*corners, *names)
    grid = Grid.covering(np.vstack(corners), cell / units.horizontal)
    check_cells(grid, cell)
    return units, bounds, (densities, sampled), notes, cell, int(min_points), grid


def _map(runs, names, files, pipeline, backend, work, settings, classes_table, holder):
    """The map of two complete tiled runs: densities, grid, coded points, work units, levels; its
    notes in the order a map of one block gives them."""
    from ._lod import REPLICATES
    from ._maps import LABEL_FREE_SCORE, SCORE, ChangeMap, geometry_only_note, metric_levels, scheme_warnings

    s = SimpleNamespace(**settings)
    t0 = time.perf_counter()
    units, bounds, (densities, sampled_density), notes, cell, min_points, grid = _frame(runs, names, s)
    seconds = {"densities": time.perf_counter() - t0}
    labelled = runs[0].labelled and runs[1].labelled
    if runs[0].labelled != runs[1].labelled:
        notes.insert(0, geometry_only_note(names[0] if not runs[0].labelled else names[1], s.score))
    classes = classes_table if labelled else UNLABELED
    side = _unit_side(runs, bounds, grid, cell, backend.workers, int(s.memory))
    uplan = UnitPlan(str(work), grid, side, s.frame, classes, labelled, (runs[0], runs[1]), min_points, s.render,
                     s.seed, 0)
    t0 = time.perf_counter()
    tiles_of = [_code(uplan, e, runs[e], bounds[e][2], backend) for e in (0, 1)]
    unit_ids = sorted(set(tiles_of[0]) | set(tiles_of[1]))
    seconds["coding"], t0 = time.perf_counter() - t0, time.perf_counter()
    gathered = _gather(uplan, unit_ids, tiles_of, backend, len(classes))
    seconds["units"] = time.perf_counter() - t0
    table = counts_table(grid, gathered["points"], gathered["undefined"], min_points, sampled_density, cell)
    if not table["valid"].any():
        most = int((gathered["points"] - gathered["undefined"]).min(axis=0).max(initial=0))
        raise no_defined_cell(cell, min_points, names[0], names[1], most, s.min_points_rule)
    for m, k in enumerate(CHANGE_KEYS):
        table[k] = gathered["metrics"][:, m]
    sampled = {k: (gathered["mu0"][:, m], gathered["sigma"][:, m], gathered["defined"][:, m])
               for m, k in enumerate(CHANGE_KEYS)}
    epochs = [TiledEpoch(names[e], runs[e], uplan, e, tiles_of[e], {**pipeline.method(), "n_points": bounds[e][2]},
                         holder) for e in (0, 1)]
    binned = [SimpleNamespace(classes=gathered["classes"][e]) for e in (0, 1)]
    schemes = scheme_warnings(binned, classes, names, ranked_by=s.score)[0] if labelled else []
    score = s.score or (SCORE if labelled and not schemes else LABEL_FREE_SCORE)
    method = {k: v for k, v in pipeline.method().items()
              if k in ("descriptor", "strategy", "scale_kind", "scale_values", "scale_units", "weights")}
    t0 = time.perf_counter()
    levels = metric_levels(table, sampled=sampled, confidence=s.confidence)
    few = [n for n in [few_cells_note(int(table["valid"].sum()))] if n]
    cm = ChangeMap(table, gathered["classes"][0], gathered["classes"][1], grid, runs[0].sources[0].crs, units, cell,
                   min_points, score, s.render, classes, epochs[0], epochs[1], s.frame, method, levels, s.confidence,
                   warnings=notes + schemes + few, timings={"lod": time.perf_counter() - t0, "replicates": 2 * REPLICATES})
    cm.rank_by(score)
    cm.cell_rule, cm.min_points_rule = s.cell_rule, s.min_points_rule
    cm.density, cm.sampled = tuple(densities), tuple(sampled_density)
    cm.timings["units"] = {"units": len(unit_ids), "side_cells": side, "reused": gathered["reused"]}
    cm.timings.update({f"{k}_seconds": v for k, v in seconds.items()})
    return cm


def _densities(run, tiles, backend):
    """Points per m² of an epoch's kept points (its staged ``run``, processing ``tiles``) over
    the 10 m pixels they occupy, as :func:`~lidar_sig.change_map._density.density` gives for
    one block (the pixels from the epoch's lowest kept point); a failed tile raises
    :class:`_TaskFailed`."""
    from ._density import DENSITY_PIXEL

    lo, _, n, _ = staged_bounds(run)
    pixel = density_pixel(run.ctx.factors[0])
    items = [(run, ij, tuple(lo[:2]), pixel) for ij in tiles]
    keys = []
    with step("density", tiles=len(items)) as st:
        for (_, ij, _, _), found, err in st.track(backend.run(density_task, items), total=len(items), unit="tile"):
            if err is not None:
                raise err if isinstance(err, LidarSigError) else _TaskFailed(err, ij)
            keys.append(found)
    occupied = len(np.unique(np.concatenate(keys))) if keys else 0
    return n / (max(occupied, 1) * DENSITY_PIXEL ** 2)


def _unit_side(runs, bounds, grid, cell, workers, memory):
    """Cells per side of a work unit: as many as hold both epochs' points within ``memory`` (above
    the base of a process, :data:`lidar_sig.tiling.memory.BASE_BYTES`) at their densest staging
    cells, and at least :data:`UNITS_PER_WORKER` units per worker."""
    from ..tiling.sources import densest

    from ..tiling.memory import BASE_BYTES

    dense = sum(densest({i: r for i, r in enumerate(b[3])}, run.plan.cells, run.ctx.factors)
                for run, b in zip(runs, bounds))
    points = max((memory - BASE_BYTES) // UNIT_BYTES_PER_POINT, 1)  # above what a process holds before any point
    side = max(1, int(math.sqrt(points / max(dense * cell * cell, 1e-12))))
    spread = max(1, math.ceil(math.sqrt(grid.n_cells / (UNITS_PER_WORKER * max(workers, 1)))))
    return min(side, spread)


def _code(uplan, e, run, n_points, backend):
    """Code an epoch's tiles (:func:`~lidar_sig.change_map._units.code_task`); {unit: [tiles]}."""
    step_ = max(1, math.ceil(n_points / VIEW_POINTS))
    tiles_of = {}
    items = [(uplan, e, ij, step_) for ij in run.tile_stats]
    with step(f"coding epoch {'AB'[e]}", tiles=len(items), points=n_points) as st:
        for (_, _, ij, _), counts, err in st.track(backend.run(code_task, items), total=len(items), unit="tile"):
            if err is not None:
                raise _failed(err, ij, uplan.work)
            for u in counts:
                tiles_of.setdefault(int(u), []).append(ij)
    return tiles_of


def _gather(uplan, units, tiles_of, backend, n_classes):
    """Every cell's values over the grid from the work units' results."""
    n, k = uplan.grid.n_cells, len(CHANGE_KEYS)
    out = {"points": np.zeros((2, n), np.int64), "undefined": np.zeros((2, n), np.int64),
           "classes": np.zeros((2, n, n_classes), np.int64), "metrics": np.full((n, k), np.nan),
           "mu0": np.full((n, k), np.nan), "sigma": np.full((n, k), np.nan), "defined": np.zeros((n, k), bool),
           "reused": 0}
    items = [(uplan, u, (tiles_of[0].get(u, []), tiles_of[1].get(u, []))) for u in units]
    with step("work units", units=len(items), side=f"{uplan.side} cells"):
        for (_, u, _), res, err in progress(backend.run(unit_task, items), total=len(items), desc="cells",
                                            unit="unit"):
            if err is not None:
                raise _failed(err, f"work unit {u}", uplan.work)
            cells = res["cells"]
            out["reused"] += bool(res.get("resumed"))
            for name in ("points", "undefined", "classes"):
                out[name][:, cells] = res[name]
            for name in ("metrics", "mu0", "sigma", "defined"):
                out[name][cells] = res[name]
    return out


class _TaskFailed(Exception):
    """A task that failed inside an epoch's tiled run (``err``, on tile or unit ``what``): not
    the user's error, so that the run keeps its work for a resumed run (a LidarSigError would
    keep only finished tiles); the map says it, naming its work folder (:func:`_failed`)."""

    def __init__(self, err, what):
        super().__init__(str(err))
        self.err, self.what = err, what


def _failed(err, what, work):
    """The LidarSigError of a task that failed: its own, or one naming the tile or unit, the
    reason and the work folder (kept for a resumed run)."""
    if isinstance(err, LidarSigError):
        return err
    where = f"tile {what[0]}, {what[1]}" if isinstance(what, tuple) else what
    again = ("run the same command with --resume" if FACE.get() == "cli" else
             f"call again with resume=True, work={str(work)!r}")
    return LidarSigError(f"{where} of the change map failed ({type(err).__name__}: {err}); free space or check the "
                         f"work folder, then {again}", path=work)


def check_streamed(path: str | os.PathLike[str], n_files: int, name: object) -> None:
    """Refuse a per-point change that a map in work units cannot stream: not LAS/LAZ, or a later
    epoch ``name`` of several files (the per-point change of one file is written)."""
    from ..io.formats import format_of

    fmt = format_of(path)
    if fmt is None or not fmt.streamed:
        raise LidarSigError("a change map in work units streams the per-point change to LAS/LAZ only: give a .las or "
                            ".laz name, or raise --memory to map the epochs in one block", path=path)
    if n_files != 1:
        raise LidarSigError(f"the later epoch {name} is {n_files} files: a change map in work units writes the "
                            "per-point change of one file; give the later epoch as one file, leave out --points, or "
                            "raise --memory to map the epochs in one block", path=path)
