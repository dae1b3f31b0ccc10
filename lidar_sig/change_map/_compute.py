"""The change map of two epochs or more from their files (:func:`changes`, `lidar-sig changes`):
read the epochs, check them, choose the cell size and the fewest points from their densities,
compute each epoch's saliency once, then per interval (consecutive pair) the cells' metrics,
their level of detection and the ranking."""
from __future__ import annotations

import time
import warnings
from typing import TYPE_CHECKING, Any, overload

import numpy as np

from ..method.class_maps import merge_classes
from ..method.classes import UNLABELED
from ..base.errors import LidarSigError, LidarSigWarning, amount, counted, whole_number, yes_no
from ..metrics import METRIC, METRIC_KEYS
from ..base.progress import step
from ..method.signature_raster import Frame, method_differences
from ..numerics.bounds import bounds
from ..io.clip import clip_inputs
from ._cells import CELL_FRAME, SEED, bin_points, cell_table, in_sample, point_keys
from ._cores import cell_values
from ._density import (AUTO, SAMPLE_DENSITY, auto_cell, auto_min_points, density, fewer_points, no_defined_cell,
                       sample_fraction, sparse_note)
from ._density import sample_density as sample_rule
from ._epochs import Epoch, check_same_crs, epoch_name, read_epoch
from ._grid import Grid, check_cell, check_cells, check_overlap, check_span
from ._lod import CONFIDENCE, REPLICATES, few_cells_note
from ._maps import LABEL_FREE_SCORE, SCORE, ChangeMap, geometry_only_note, metric_levels, scheme_warnings
from .series import ChangeSeries
from ._in_units import changes_in_units, in_units

if TYPE_CHECKING:
    from ..pipeline.flow import Pipeline



@overload
def changes(a: Any, b: Any, /, *, cell: float | str = AUTO, pipeline: Pipeline | None = None,
            min_points: int | str = AUTO, score: str | None = None, render: str = "smooth", frame: Frame = CELL_FRAME,
            columns: Any = None, confidence: float = CONFIDENCE, class_map: Any = None, seed: int = SEED,
            execution: Any = None, resume: bool = False, work: Any = None, aoi: Any = None,
            sample_density: float | str | None = AUTO) -> ChangeMap:
    ...


@overload
def changes(a: Any, b: Any, c: Any, /, *more: Any, cell: float | str = AUTO, pipeline: Pipeline | None = None,
            min_points: int | str = AUTO, score: str | None = None, render: str = "smooth", frame: Frame = CELL_FRAME,
            columns: Any = None, confidence: float = CONFIDENCE, class_map: Any = None,
            seed: int = SEED, execution: Any = None, resume: bool = False, work: Any = None,
            aoi: Any = None, sample_density: float | str | None = AUTO) -> ChangeSeries:
    ...


def changes(a: Any, b: Any, *more: Any, cell: float | str = AUTO, pipeline: Pipeline | None = None,
            min_points: int | str = AUTO, score: str | None = None, render: str = "smooth", frame: Frame = CELL_FRAME,
            columns: Any = None, confidence: float = CONFIDENCE, class_map: Any = None,
            seed: int = SEED, execution: Any = None, resume: bool = False,
            work: Any = None, aoi: Any = None, sample_density: float | str | None = AUTO) -> ChangeMap | ChangeSeries:
    """Per-cell change map between epochs of the same area (registration-free), with a level of
    detection per cell and metric.

    Parameters
    ----------
    a, b, *more : str, Path, list of paths, folder, PointCloud or Epoch
        The epochs in time order: point-cloud files, folders of tiles or lists of tile files
        (joined into one cloud per epoch), clouds, or epochs whose saliency is computed already
        (:func:`~lidar_sig.change_map.compute_epoch`, with the same method). All must be in the
        same CRS. Three or more give a :class:`~lidar_sig.change_map.ChangeSeries` (a map per
        consecutive pair).
    cell : float or "auto"
        Cell side in metres (converted to the CRS unit); ``"auto"`` (default) chooses it from
        the smallest density of the epochs (:mod:`~lidar_sig.change_map._density`).
    pipeline : Pipeline, optional
        The method of the saliency; default ``Pipeline()`` (docs/method.md).
    min_points : int or "auto"
        Fewest points with defined saliency a cell must hold in each epoch to be compared;
        ``"auto"`` (default): a fifth of a full cell at the smallest density, at least 30.
    score : str, optional
        Metric that ranks the cells (a key of :data:`lidar_sig.metrics.METRIC_KEYS`; for
        s_SSIM, 1 - SSIM ranks); default :data:`~lidar_sig.change_map.SCORE` (delta_KL), or
        :data:`~lidar_sig.change_map.LABEL_FREE_SCORE` (delta_FV) when an epoch is unlabelled
        or the epochs' class codes barely overlap.
    render : str: rendering of Sg and Sas for the image metrics (:mod:`lidar_sig.method.signature_raster`).
    frame : Frame: of the per-cell signatures; default :data:`~lidar_sig.change_map.CELL_FRAME` (64 px).
    confidence : float
        Confidence of the significance test, one-sided, from 0.5 to 0.9999; default 0.95.
    class_map : str, list, dict or path, optional
        Codes of either epoch merged into one class before the comparison, e.g.
        ``"1,3,4,5=vegetation-or-other"`` (see :func:`lidar_sig.method.class_maps.parse_class_map`).
    seed : int
        Seed of the resampling behind the level of detection (each cell has its own stream).
    execution : Execution, optional
        Memory budget of each process, workers or a Dask scheduler (default: 1 GiB, all cores).
        Two epochs of LAS/LAZ files whose one block would need more than the budget, or with a tile size,
        workers or a scheduler asked, are mapped in work units (docs/changes.md): the same map, in bounded memory.
    resume : bool
        Reuse what an interrupted run in work units finished in its work folder (``work``).
    work : str or Path, optional
        Work folder of a run in work units (default: a new one in the execution's ``work_dir`` or the
        temporary folder, removed with the map's ``close()``).
    aoi : str, path or tuple, optional: an area of interest the epochs are clipped to first (docs/scale-out.md).
    sample_density : float, "auto" or None: an epoch's points per m² its cells take at most, a sample of a
        denser one ("auto": 5, more for cells under 25 m; None: every point; docs/changes.md).

    Returns
    -------
    ChangeMap, or ChangeSeries for three epochs or more
    """
    if (clip := clip_inputs([a, b, *more], aoi)).reading is not None:  # clipped to the area, or fetched from a server
        return _clipped(clip, {k: v for k, v in locals().items() if k not in ("a", "b", "more", "aoi", "clip")})
    from ..pipeline.flow import pipeline_or_default
    from ..tiling.execution import as_execution
    sources = (a, b) + more
    s = _settings(cell, min_points, confidence, score, frame, seed, sample_density)
    resume = _checked_flags(columns, resume)
    pipeline = pipeline_or_default(pipeline)
    table_of_classes = merge_classes(pipeline.classes, class_map)  # a bad map is refused before reading
    execution = as_execution(execution)
    s.workers = execution.workers  # the cells' processes of a map of one block (None: every core)
    files = None if any(isinstance(x, Epoch) for x in sources) else in_units(sources, execution, pipeline, resume)
    if files is None and (resume or work is not None):
        raise LidarSigError("resume and work are for a change map in work units: two epochs of LAS/LAZ files with "
                            "a tile size, workers or a scheduler (Execution), or above the memory budget")
    if files is not None:
        return _in_units(sources, files, pipeline, execution, resume, work, table_of_classes, class_map,
                         dict(vars(s), render=render, memory=execution.memory))
    if execution.tiles_asked:
        warnings.warn("the epochs are mapped in one block: work units take two epochs of LAS/LAZ files (the tile "
                      "size and scheduler are not used; the workers compute the cells)", LidarSigWarning, stacklevel=2)
    given, clouds, names, labelled, notes = _read(sources, pipeline, columns, s.score, class_map)
    units, kept, samples, densities, grid = _layout(clouds, given, names, pipeline, s, notes)
    return _maps(clouds, names, given, kept, samples, pipeline, table_of_classes, labelled, grid, units, densities, s,
                 render, notes)


def _clipped(clip, options):
    """The map of the clipped epochs of ``clip`` (:class:`lidar_sig.io.clip.Clipped`), whose
    copies last as long as the map does (its points are read again when written)."""
    import weakref

    try:
        mapped = changes(*clip.inputs, **options)  # every other argument as given
    except BaseException:
        clip.cleanup()
        raise
    weakref.finalize(mapped, clip.cleanup)
    mapped.reading = clip.reading
    return mapped


def _maps(clouds, names, given, kept, samples, pipeline, table_of_classes, labelled, grid, units, densities, s,
          render, notes):
    """Each epoch's saliency (once, of its sample), its points binned, then the map of each
    interval (a ChangeMap, or a ChangeSeries of three epochs or more); ``samples`` are each
    epoch's sample (None: every point) and its points' keys (None: not computed yet),
    ``densities`` the epochs' and their samples' points per m²."""
    densities, sampled = densities
    samples, keys = samples
    epochs, seconds = [], []
    for cloud, name, epoch, used_points, sample, key in zip(clouds, names, given, kept, samples, keys):
        start = time.perf_counter()
        if epoch is None:
            sal, stats = pipeline.saliency(cloud, query=sample)
            epoch = Epoch(name, cloud, sal, stats, kept=used_points, keys=key)
        elif used_points is not epoch.kept:  # computed whole: its cells take the sample
            epoch = Epoch(epoch.name, epoch.cloud, epoch.saliency, epoch.metadata, kept=used_points, keys=key)
        seconds.append(time.perf_counter() - start)
        epochs.append(epoch)
    classes = table_of_classes if labelled else UNLABELED
    with step("binning", epochs=len(epochs), cells=grid.n_cells):
        binned = [bin_points(e, grid, classes, labelled, s.frame) for e in epochs]
    schemes = scheme_warnings(binned, classes, names, ranked_by=s.score) if labelled else [[]] * (len(epochs) - 1)
    score = s.score or (SCORE if labelled and not any(schemes) else LABEL_FREE_SCORE)
    method = {k: epochs[0].metadata[k] for k in ("descriptor", "strategy", "scale_kind", "scale_values",
                                                 "scale_units", "weights") if k in epochs[0].metadata}
    maps = []
    for k in range(len(epochs) - 1):
        maps.append(_interval(k, epochs, binned, grid, classes, s, render, score, method, units, names,
                              sampled[k:k + 2]))
        cm = maps[-1]
        cm.cell_rule, cm.min_points_rule = s.cell_rule, s.min_points_rule
        cm.density, cm.sampled = (densities[k], densities[k + 1]), (sampled[k], sampled[k + 1])
        cm.timings["saliency"] = [seconds[k], seconds[k + 1]]
        cm.warnings = notes + schemes[k] + cm.warnings
    for text in dict.fromkeys(w for m in maps for w in m.warnings):  # each once
        warnings.warn(text, LidarSigWarning, stacklevel=3)
    return maps[0] if len(maps) == 1 else ChangeSeries(maps, epochs)


def _checked_flags(columns, resume):
    """``resume`` as a bool, and ``columns`` checked: both refused at the call, before any file is
    read (a text is no flag: ``resume="no"`` is true to Python)."""
    if columns is not None:
        from ..io import parse_columns

        parse_columns(columns)
    return yes_no(resume, "resume")


def _settings(cell, min_points, confidence, score, frame, seed, sample_density=SAMPLE_DENSITY):
    """The checked settings of :func:`changes` (a LidarSigError naming a bad one): the cell and
    fewest points (None for "auto") and how each was chosen, the confidence, score, frame, seed
    and the sample's density (None: every point)."""
    from types import SimpleNamespace

    cell_rule = AUTO if _is_auto(cell) else "given"
    cell = None if cell_rule == AUTO else check_cell(cell)
    min_points_rule = AUTO if _is_auto(min_points) else "given"
    min_points = None if min_points_rule == AUTO else whole_number(min_points, "min_points", low=1)
    if isinstance(confidence, bool) or not isinstance(confidence, (int, float)) or not 0.5 <= confidence <= 0.9999:
        raise LidarSigError(f"the confidence must be a number from 0.5 to 0.9999 (e.g. 0.95), got {confidence!r}")
    if score is not None and score not in METRIC_KEYS:
        raise LidarSigError(f"unknown score {score!r}; use one of {', '.join(METRIC_KEYS)}")
    if not isinstance(frame, Frame):
        raise LidarSigError(f"frame must be a lidar_sig.Frame, got {frame!r}")
    if _is_auto(sample_density):
        sample_density = AUTO
    elif sample_density is not None and (isinstance(sample_density, bool) or not isinstance(sample_density, (int, float))
                                         or not 0 < sample_density < float("inf")):
        raise LidarSigError(f"sample_density must be a positive number of points per m² (e.g. {SAMPLE_DENSITY:g}), "
                            f"'auto' or None for every point, got {sample_density!r}")
    return SimpleNamespace(cell=cell, cell_rule=cell_rule, min_points=min_points, min_points_rule=min_points_rule,
                           confidence=confidence, score=score, frame=frame, seed=whole_number(seed, "seed"),
                           sample_density=sample_rule(sample_density if sample_density in (None, AUTO)
                                                      else float(sample_density), cell))


def _read(sources, pipeline, columns, score, class_map):
    """(given epochs or None, clouds, names, labelled, notes) of the epochs ``sources``: read,
    in one CRS, labelled as the score and the class map need."""
    given = [x if isinstance(x, Epoch) else None for x in sources]  # saliency computed already
    for x in given:
        differ = [] if x is None else method_differences(x.metadata, pipeline.method())
        if differ:
            raise LidarSigError(f"the epoch {x.name} was computed with another method ({'; '.join(differ)}); give "
                                "the pipeline it was computed with, or its cloud")
    clouds = [read_epoch(x, columns=columns) for x in sources]
    names = [x.name if x is not None else c.path or "(in memory)" for x, c in zip(given, clouds)]
    for k in range(1, len(clouds)):
        check_same_crs([clouds[0], clouds[k]], [names[0], names[k]])
    labelled = all(c.labels is not None for c in clouds)
    notes = []
    if not labelled and any(c.labels is not None for c in clouds):
        notes.append(geometry_only_note(", ".join(n for n, c in zip(names, clouds) if c.labels is None), score))
    if score in METRIC and METRIC[score].needs_labels and not labelled:
        raise LidarSigError(f"score {score!r} needs class labels in every epoch; use fv or another geometric metric")
    if class_map and not labelled:
        raise LidarSigError("a class map merges class codes, but not every epoch has class labels; leave out "
                            "--class-map")
    return given, clouds, names, labelled, notes


def _layout(clouds, given, names, pipeline, s, notes):
    """(units, the points each run uses, densities, grid) of the epochs, with the cell and fewest
    points chosen in ``s`` where "auto" and a note in ``notes`` below the least density; refused
    before any saliency where the epochs share no land or no cell holds the fewest points."""
    units = clouds[0].units
    # the points each run uses: withheld and noise points count neither in the densities nor
    # in the grid's extent, as they are in no cell
    kept = [pipeline.kept(c) if x is None else x.kept for x, c in zip(given, clouds)]
    used = [c.xyz[:, :2] if k is None else c.xyz[k, :2] for c, k in zip(clouds, kept)]
    densities = [density(xy, units.horizontal) for xy in used]
    notes += [n for n in [sparse_note(names, densities)] if n]
    # each epoch's cells take a sample of at most SAMPLE_DENSITY points per m², by the points'
    # keys; the rules count the sample's points, at its expected density
    fractions = [sample_fraction(d, s.sample_density) for d in densities]
    keys = [point_keys(c.xyz, c.labels) if f < 1.0 else None for c, f in zip(clouds, fractions)]  # binned again
    samples = [in_sample(c.xyz, c.labels, f, k) for c, f, k in zip(clouds, fractions, keys)]
    kept = [k if q is None else (q if k is None else k & q) for k, q in zip(kept, samples)]
    sampled = [d * f for d, f in zip(densities, fractions)]
    if s.cell is None:
        s.cell = auto_cell(min(sampled))
    if s.min_points is None:
        s.min_points = auto_min_points(min(sampled), s.cell)
    for k in range(len(clouds) - 1):  # before the grid: disjoint epochs would span a needless one
        check_overlap(used[k], used[k + 1], names[k], names[k + 1])
    corners = np.vstack([np.vstack(bounds(xy)) for xy in used])  # not every point stacked
    check_span(corners, s.cell / units.horizontal, s.cell)
    grid = Grid.covering(corners, s.cell / units.horizontal)
    check_cells(grid, s.cell)
    counts = [np.bincount(grid.cell_of(c.xyz[:, :2] if k is None else c.xyz[k, :2]), minlength=grid.n_cells)
              for c, k in zip(clouds, kept)]
    for k in range(len(clouds) - 1):  # said before the saliency is computed
        filled = np.minimum(counts[k], counts[k + 1])
        if filled.max() < s.min_points:
            pair = "" if len(clouds) == 2 else f" {names[k]} and {names[k + 1]}"
            fix = fewer_points(s.min_points_rule, s.min_points)
            raise LidarSigError(f"no cell of {s.cell:g} m holds {counted(s.min_points, 'point')} in both "
                                f"epochs{pair} (at most {amount(filled.max())}); {fix}")
    return units, kept, (samples, keys), (densities, sampled), grid


def _in_units(sources, files, pipeline, execution, resume, work, table_of_classes, class_map, settings):
    """The map of two epochs of LAS/LAZ ``files`` in work units (:mod:`~lidar_sig.change_map._in_units`)."""
    from pathlib import Path

    from ..tiling.work import discard_work, fresh_work, remove_work

    names = [epoch_name(x, [x] if isinstance(x, (str, Path)) and Path(x).is_file() else f)
             for x, f in zip(sources, files)]
    own = work is None  # a folder of the map's own, in the temporary folder
    remove = discard_work if own else remove_work
    work = fresh_work(execution.work_dir) if own else Path(work)
    try:
        cm = changes_in_units(files, names, pipeline=pipeline, execution=execution, work=work, resume=resume,
                              settings=settings, classes_table=table_of_classes, remove=remove, own=own)
    except BaseException as exc:
        # a folder of the map's own goes, unless the error says it is kept for a resumed run
        # (with resume=True and work= that folder)
        if own and not (isinstance(exc, LidarSigError) and str(work) in str(exc)):
            remove(work)
        raise
    # said once the epochs' labels are known; a given work folder stays for a run without them
    if class_map and cm.class_table is UNLABELED:
        raise LidarSigError("a class map merges class codes, but not every epoch has class labels; leave out "
                            "--class-map")
    if settings["score"] in METRIC and METRIC[settings["score"]].needs_labels and cm.class_table is UNLABELED:
        raise LidarSigError(f"score {settings['score']!r} needs class labels in every epoch; use fv or another "
                            "geometric metric")
    for text in dict.fromkeys(cm.warnings):
        warnings.warn(text, LidarSigWarning, stacklevel=3)
    return cm


def _interval(k, epochs, binned, grid, classes, s, render, score, method, units, names, densities):
    """The ChangeMap of epochs k and k + 1: table, metrics, levels of detection, ranking."""
    min_points, cell, frame, confidence, seed = s.min_points, s.cell, s.frame, s.confidence, s.seed
    min_points_rule = s.min_points_rule
    pair = binned[k:k + 2]
    table = cell_table(grid, pair, min_points, densities, cell)
    if not table["valid"].any():  # the points are there, their saliency is not
        most = int(np.minimum(table["defined_a"], table["defined_b"]).max())
        raise no_defined_cell(cell, min_points, names[k], names[k + 1], most, min_points_rule)
    n_valid = int(table["valid"].sum())
    timings = {}
    start = time.perf_counter()
    # the cells' metrics and the resamples of their level of detection, in one pass over the cells
    with step("cell metrics", cells=n_valid, cell=f"{cell:g} m", frame=f"{frame.size} px",
              replicates=2 * REPLICATES) as st:
        null = cell_values(table, pair, classes, render=render, frame=frame, seed=seed, stream=k, progress=st,
                           workers=s.workers)
    timings["cells"] = time.perf_counter() - start
    start = time.perf_counter()
    with step("level of detection", cells=n_valid):
        levels = metric_levels(table, null, confidence=confidence)
    timings["lod"] = time.perf_counter() - start
    notes = [n for n in [few_cells_note(n_valid)] if n]
    cm = ChangeMap(table, pair[0].classes, pair[1].classes, grid, epochs[k].cloud.crs, units, cell, int(min_points),
                   score, render, classes, epochs[k], epochs[k + 1], frame, method, levels, confidence,
                   warnings=notes, timings=timings)
    cm.rank_by(score)
    return cm


def _is_auto(value):
    return isinstance(value, str) and value.strip().lower() == AUTO
