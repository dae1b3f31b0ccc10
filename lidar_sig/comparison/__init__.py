"""Comparing two clouds, or their archives, with one method (docs/method.md, "Metrics"): `lidar-sig compare`, and
the report of one input or of two compared (:func:`report`).

Both sides must be made the same way: two clouds are computed with one pipeline (the same k, or
the same radii in metres); a cloud compared with an archive is computed the way the archive was
made; two archives must record the same method, class table and frame. The image metrics render
both signatures alike (the counts are lossless, so any rendering can be chosen afterwards).
Warnings say what may make the figures mislead, and nothing else. An input is a path, a
PointCloud, a Signature or a pipeline Result; :class:`Side` holds one as compared and reported.
"""
from __future__ import annotations

import os
import warnings
from dataclasses import dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ..method.class_maps import class_scheme_warnings
from ..method.cloud import PointCloud
from ..base.errors import LidarSigError, LidarSigWarning, a_kind, arg, as_path, counted
from ..metrics import compare as compare_signatures
from ..base.progress import step
from ..method.scales import ScaleKind, recorded_kind, recorded_scales
from ..method.signature_raster import RENDERINGS, Signature, method_differences

if TYPE_CHECKING:
    from ..reporting import Report

#: Share of a cloud's points with undefined saliency above which compare warns.
UNDEFINED_WARNING = 0.05
#: Normalized radii resolving to metric radii further apart than this get a warning.
RADII_TOLERANCE = 0.10


@dataclass
class Side:
    """One input of a comparison: where it came from, its signature and, for a cloud, the run."""

    name: str
    signature: Signature
    result: object = None  # pipeline Result for a cloud, None for an archive or a set of tiles
    tiled: bool = False  # computed as a set of tiles (a folder, or a file over the memory budget)
    in_memory: bool = False  # a Signature given as it is, not read from an archive file

    @property
    def kind(self) -> str:
        """"cloud", "set of tiles", "archive" (a signature file) or "signature" (given in memory)."""
        if self.result is not None:
            return "cloud"
        return "set of tiles" if self.tiled else "signature" if self.in_memory else "archive"

    def summary(self) -> dict[str, Any]:
        """The side's facts for people and JSON: points, undefined, capped, duplicates, withheld
        or noise points left out (excluded), scales, units."""
        m = self.signature.metadata
        return {"path": self.name, "kind": self.kind, "points": int(m.get("n_points", self.signature.n_points)),
                "undefined": int(m.get("n_undefined", self.signature.n_undefined)),
                "capped": int(m.get("n_capped", 0)), "duplicates": int(m.get("n_duplicates", 0)),
                "excluded": int(m.get("n_excluded", 0)),
                "scale_kind": m.get("scale_kind"), "scales": list(m.get("resolved_scales", [])),
                "scales_unit": (recorded_kind(m) or ScaleKind.RADIUS).unit,
                "units": m.get("units", "unknown")}


class Comparison(dict):
    """The result of :func:`compare`: a dict of every metric (key -> value; None for a metric the
    inputs cannot give, such as delta_KL without labels), with both sides (``a``, ``b``: each a
    :class:`Side`), the ``render``-ing the image metrics were computed under, the ``method`` both
    were made with, and the ``warnings`` of the run (what may make the figures mislead)."""

    def __init__(self, a: Side, b: Side, metrics: dict, render: str, method: dict,
                 warnings: list | None = None) -> None:
        super().__init__(metrics)
        self.a, self.b, self.render, self.method = a, b, render, method
        self.warnings = list(warnings or [])

    @property
    def metrics(self) -> dict:
        """The metrics as a plain dict."""
        return dict(self)

    def __repr__(self) -> str:
        shown = ", ".join(f"{k} {'n/a' if v is None else format(v, '.4g')}" for k, v in self.metrics.items())
        from ..base.views import one_line, short_name

        return one_line(f"<Comparison {short_name(self.a.name)} vs {short_name(self.b.name)}: {shown}>")

    def _repr_html_(self) -> str:
        """A notebook's view: the metrics with their ranges and what each reacts to."""
        from ..metrics import METRICS
        from ..base.views import card

        rows = [(m.name, "n/a" if self.metrics[m.key] is None else f"{self.metrics[m.key]:.4f}", m.range,
                 f"{m.same:g}", m.reacts) for m in METRICS]
        facts = [f"{side.kind} {side.name}: {side.summary()['points']:,} points" for side in (self.a, self.b)]
        facts.append(f"rendering {self.render}")
        return card("Comparison", facts + [f"warning: {w}" for w in self.warnings],
                    header=("metric", "value", "range", "same", "reacts to"), rows=rows, numeric=(1,))

    def __reduce__(self):
        return (type(self), (self.a, self.b, dict(self), self.render, self.method, self.warnings))

    def to_dict(self) -> dict[str, Any]:
        """Everything as plain JSON-able values: the metrics at the top level (as before),
        ``a`` and ``b`` with each side's facts, ``method``, ``render``, ``warnings`` and each
        metric placed on the project's reference values (``scale``, :meth:`Metric.scale`)."""
        out = dict(self.metrics)
        out.update(a=self.a.summary(), b=self.b.summary(), method=self.method, render=self.render,
                   warnings=list(self.warnings), scale=metric_scales(self.metrics))
        return out

    def report(self) -> Report:
        """The HTML report of this comparison (:class:`lidar_sig.reporting.Report`): shown in
        a notebook, ``.save("report.html")`` writes it."""
        from ..reporting import comparison_report

        return comparison_report(self)


def compare(a: Any, b: Any, *, pipeline: Any = None, render: str | None = None, columns: Any = None,
            execution: Any = None, color_bins: int = 8) -> Comparison:
    """Every metric between two clouds or their signatures (docs/method.md, "Comparison
    metrics"), both made the same way, as a :class:`Comparison` (a mapping of metric key to
    value).

    Parameters
    ----------
    a, b : path, PointCloud, Signature or Result
        Point-cloud files (.las/.laz, .ply, .pcd, text), signature archives (.h5), folders of
        LAS/LAZ tiles (an epoch, processed in tiles), clouds, signatures or pipeline results,
        in any mix: what :func:`report` takes.
    pipeline : Pipeline, optional
        The method for clouds; default ``Pipeline()``; an archive brings its own.
    render : str, optional
        Rendering of Sg and Sas for the image metrics; default the archives' own, else "smooth".
    columns : str or list, optional
        Columns of text clouds.
    execution : Execution, optional
        Memory budget and tiles (see :func:`compare_sources`).
    color_bins : int
        Bins per RGB channel of the colour histograms (d_BD-Img, d_EMD-Img).

    >>> import lidar_sig as ls                                                    # doctest: +SKIP
    >>> ls.compare("epoch1.laz", "epoch2.laz")["l1"]                              # doctest: +SKIP
    0.1558...
    """
    # a pipeline given is the whole method the caller means: an archive made otherwise is refused
    given = ("pipeline",) if pipeline is not None else ()
    return compare_sources(a, b, pipeline, render=render, columns=columns, execution=execution,
                           color_bins=color_bins, method_given=given)


def metric_scales(values):
    """{metric key: :meth:`lidar_sig.metrics.Metric.scale`} of the metrics that have a value."""
    from ..metrics import METRICS

    return {m.key: m.scale(values[m.key]) for m in METRICS if values.get(m.key) is not None}


def report(a: Any, b: Any = None, pipeline: Any = None, *, render: str | None = None, columns: Any = None) -> Report:
    """The report of one cloud, or of the comparison of two (:mod:`lidar_sig.reporting`).

    Parameters
    ----------
    a, b : str, Path, PointCloud, Signature, Result or Comparison
        Clouds or archives as :func:`compare_sources` takes them (``b`` None for one cloud's
        report), a pipeline ``Result``, or an already made ``Comparison``.
    pipeline : Pipeline, optional
        The method for clouds; default ``Pipeline()``.
    render : str, optional
        Rendering of Sg and Sas (see :mod:`lidar_sig.method.signature_raster`); default "smooth".

    >>> import lidar_sig as ls                                         # doctest: +SKIP
    >>> ls.report("epoch1.laz", "epoch2.laz").save("report.html")      # doctest: +SKIP
    """
    from ..reporting import comparison_report, signature_report

    if isinstance(a, Comparison):
        return comparison_report(a)
    if b is not None:
        given = ("pipeline",) if pipeline is not None else ()
        return comparison_report(compare_sources(a, b, pipeline, render=render, columns=columns, method_given=given))
    return signature_report(side_of(a, pipeline, columns), render=render or "smooth")


def side_of(x, pipeline=None, columns=None):
    """The :class:`Side` of one input: a pipeline Result as it is, an archive loaded, a cloud
    read and run through ``pipeline`` (default ``Pipeline()``)."""
    from ..pipeline.flow import Pipeline
    from ..pipeline.result import Result

    if isinstance(x, Result):
        return Side(input_name(x), x.signature, x)
    loaded = load_input(x, columns)
    if isinstance(loaded, Signature):
        return Side(input_name(x), loaded, in_memory=isinstance(x, Signature))
    result = (pipeline or Pipeline()).run(loaded)
    return Side(input_name(x), result.signature, result)


def compare_sources(a: Any, b: Any, pipeline: Any = None, *, render: str | None = None, columns: Any = None,
                    method_given: Any = (), execution: Any = None, color_bins: int = 8) -> Comparison:
    """Compare two point clouds or signature archives, in any mix (docs/method.md, "Metrics").

    Parameters
    ----------
    a, b : str, Path, PointCloud or Signature
        Point-cloud files (.las/.laz, .ply, .pcd, text), archives (.h5), clouds or signatures.
    pipeline : Pipeline, optional
        The method for clouds; default ``Pipeline()``. Ignored where an archive brings its own
        method, unless ``method_given`` names options the user set, which must then agree.
    render : str, optional
        Rendering for the image metrics (see :mod:`lidar_sig.method.signature_raster`); by default the
        archives' own when they agree, else "smooth".
    columns : tuple, optional
        Column names of text clouds.
    execution : Execution, optional
        How a folder of LAS/LAZ tiles given as a or b (an epoch) is processed as one set in
        tiles (:mod:`lidar_sig.tiling`): tile size, workers, scheduler; when any of them is
        set, a LAS/LAZ file is processed in tiles too. Its memory budget (default 1 GiB per
        process): a LAS/LAZ file that needs more as one block is processed in tiles, as a set
        is (a worker process per core unless ``workers`` says otherwise).
    """
    from ..pipeline.flow import pipeline_or_default
    from ..pipeline.result import Result
    from ..tiling.execution import as_execution

    pipeline = pipeline_or_default(pipeline)
    execution = as_execution(execution)
    for x, what in zip((a, b), "ab"):  # a path the system cannot take is named first
        if isinstance(x, (str, os.PathLike)):
            as_path(x, what)
    names = [input_name(x) for x in (a, b)]
    as_set = execution.tiles_asked
    # archives first: an archive's method is the one its other side is computed with, and that
    # method decides whether a large LAS/LAZ file runs in tiles (execution.over_budget)
    loaded = [load_input(x, what=what) if _holds_signature(x) else x for x, what in zip((a, b), "ab")]
    sigs = [x for x in loaded if isinstance(x, Signature)]
    if sigs:
        reference = sigs[0]
        pipeline = _archive_pipeline(reference, pipeline, method_given, names[loaded.index(reference)])
    over = [None if as_set else execution.over_budget(x, pipeline) for x in loaded]
    loaded = [load_input(x, columns, as_set or bool(n), what) for x, n, what in zip(loaded, over, "ab")]
    # a set's labels are known once it is run: with an unlabelled cloud or archive on the other
    # side, it is run without them straight away (see geometry_only below)
    unlabelled = (any(not x.classes.names for x in sigs)
                  or any(isinstance(x, PointCloud) and x.labels is None for x in loaded))
    sets = {i: _signature_of_set(x, _unlabelled(pipeline) if unlabelled else pipeline, execution, over=over[i])
            for i, x in enumerate(loaded) if isinstance(x, Path)}
    labelled = [bool(x.classes.names) if isinstance(x, Signature) else x.labels is not None
                if isinstance(x, PointCloud) else sets[i][1] for i, x in enumerate(loaded)]
    notes = []
    if any(labelled) and not all(labelled):
        notes.append("semantic metrics (kl, l1) need class labels in both clouds; comparing geometry only")
    # one cloud (or set) unlabelled, or an unlabelled archive: every cloud is one class, so that
    # the signatures stay comparable; the caller's clouds are left as they are (unlabelled copies)
    computed = [i for i, x in enumerate(loaded) if not isinstance(x, Signature)]
    geometry_only = ((len(computed) == 2 and sum(not labelled[i] for i in computed) == 1)
                     or any(not x.classes.names for x in sigs))
    if geometry_only:
        loaded = [replace(x, labels=None) if isinstance(x, PointCloud) and x.labels is not None else x
                  for x in loaded]
        for i, (sig, _) in list(sets.items()):
            if sig.classes.names:  # run with its labels before the other's were known: again without
                sets[i] = _signature_of_set(loaded[i], _unlabelled(pipeline), execution, over=over[i])
    sides = []
    for i, (name, x) in enumerate(zip(names, loaded)):
        given = (a, b)[i]
        if isinstance(x, Signature):
            sides.append(Side(name, x, given if isinstance(given, Result) else None,
                              in_memory=isinstance(given, Signature)))
        elif i in sets:  # a folder of tiles (one epoch), or a file over the memory budget
            sides.append(Side(name, sets[i][0], tiled=True))
        else:
            result = pipeline.run(x)
            sides.append(Side(name, result.signature, result))
    first, second = sides[0].signature, sides[1].signature
    differ = method_differences(first.metadata, second.metadata)
    if differ:
        raise LidarSigError(f"{names[0]} and {names[1]} were made with different methods ("
                            + "; ".join(differ) + "); make both with the same settings")
    render = render or _recorded_render(sides)
    with step("metrics", rendering=render):
        metrics = compare_signatures(first, second, render=render, color_bins=color_bins)
    notes += _undefined_warnings(sides) + _class_warnings(sides) + _radii_warnings(sides)
    method = {k: first.metadata[k] for k in ("descriptor", "descriptor_params", "strategy", "scale_kind",
                                             "scale_values", "scale_units", "weights", "keep_noise")
              if k in first.metadata}
    return Comparison(sides[0], sides[1], metrics, render, method, notes)


def input_name(x):
    """The name an input is shown under: its path, a signature's or result's source, or "(in
    memory)"."""
    from ..pipeline.result import Result

    if isinstance(x, (str, Path)):
        return str(x)
    if isinstance(x, Result):
        return x.metadata.get("source") or "(in memory)"
    return getattr(x, "path", None) or (x.metadata.get("source") if isinstance(x, Signature) else None) or "(in memory)"


def load_input(x, columns=None, as_set=False, what="the input"):
    """An input made ready to compare: a PointCloud or Signature as it is, an archive (.h5)
    loaded, a cloud file read (``columns`` of a text file), a folder of tiles (or, with
    ``as_set``, a LAS/LAZ file) as a Path to process as one set."""
    from ..io import HDF5_EXTENSIONS, LAS_EXTENSIONS, load_signature, read

    from ..pipeline.result import Result

    if isinstance(x, (PointCloud, Signature)):
        return x
    if isinstance(x, Result):  # computed already: its signature
        return x.signature
    if isinstance(x, (str, Path)):
        if Path(x).is_dir() or (as_set and Path(x).suffix.lower() in LAS_EXTENSIONS):
            return Path(x)  # processed as a set of tiles
        if Path(x).suffix.lower() in HDF5_EXTENSIONS:
            return load_signature(x)
        return read(x, columns=columns)
    raise LidarSigError(f"{what} is {a_kind(x)}: give a file path, a PointCloud, a Signature or a Result to compare")


def _holds_signature(x):
    """Whether ``x`` is a signature, a result or an archive file (.h5) rather than points."""
    from ..io import HDF5_EXTENSIONS
    from ..pipeline.result import Result

    return (isinstance(x, (Signature, Result))
            or isinstance(x, (str, Path)) and not Path(x).is_dir() and Path(x).suffix.lower() in HDF5_EXTENSIONS)


def _archive_pipeline(signature, pipeline, method_given, name):
    """The pipeline that made an archive, for the cloud compared with it; refuses options the
    user set that contradict it."""
    from ..pipeline.flow import Pipeline

    recorded = {k: signature.metadata[k] for k in signature.metadata if k in pipeline.method()}
    whole = "pipeline" in method_given  # Python: the pipeline given, all of it
    if (whole or "classes" in method_given) and signature.classes.names and pipeline.classes != signature.classes:
        raise LidarSigError(f"{name} is an archive made with class table {signature.classes.name!r}, not "
                            f"{pipeline.classes.name!r}; leave out {arg('pipeline' if whole else 'classes')} or make "
                            "the archive again with it")
    if set(method_given) - {"classes"}:
        differ = method_differences(recorded, pipeline.method())
        if differ:
            raise LidarSigError(f"{name} is an archive made with another method (" + "; ".join(differ)
                                + f"); leave out {arg('pipeline') if whole else 'the method options'} to compute "
                                "the cloud the archive's way")
    return Pipeline.from_method(recorded, classes=signature.classes, frame=signature.frame,
                                progress=pipeline.progress)


def _recorded_render(sides):
    recorded = {str(s.signature.metadata["render"]) for s in sides
                if s.kind in ("archive", "signature") and "render" in s.signature.metadata}
    if len(recorded) > 1:
        raise LidarSigError(f"the archives were rendered differently ({', '.join(sorted(recorded))}); give "
                            f"{arg('render')} ({', '.join(RENDERINGS)}) to compare both under one rendering")
    return recorded.pop() if recorded else RENDERINGS[0]


def _undefined_warnings(sides):
    out = []
    for s in sides:
        info = s.summary()
        n, undefined = info["points"], info["undefined"]
        if n and undefined / n > UNDEFINED_WARNING:
            scales = info["scales"]
            what = (recorded_kind(info) or ScaleKind.RADIUS).describe(scales)
            out.append(f"{s.name}: {undefined:,} of {n:,} points ({undefined / n:.0%}) have no defined saliency "
                       f"at {what} and are left out of its signature; use larger scales (or the default "
                       "k-nearest scales)")
    return out


def _class_warnings(sides):
    """Warn when a cloud's points are largely in classes the other cloud does not use."""
    a, b = (s.signature for s in sides)
    if not a.classes.names:
        return []
    return class_scheme_warnings(a.class_totals, b.class_totals, a.classes.class_names, [s.name for s in sides])


def _radii_warnings(sides):
    """Normalized radii resolve per cloud: warn when the two clouds' metric radii differ."""
    m = [s.signature.metadata for s in sides]
    if not all((scales := recorded_scales(x)) is not None and scales.normalized and x.get("resolved_scales")
               for x in m):
        return []
    ra, rb = m[0]["resolved_scales"][-1], m[1]["resolved_scales"][-1]
    if max(ra, rb) <= (1 + RADII_TOLERANCE) * min(ra, rb):
        return []
    return [f"normalized radii resolve to different metric radii ({ra:.4g} m in A, {rb:.4g} m in B: "
            f"{abs(ra / rb - 1):.0%} apart) because the clouds' bounding boxes differ; for the same "
            f"neighbourhoods leave out {arg('units', 'normalized')}"]


def _unlabelled(pipeline):
    """``pipeline`` with every point in one class: a run as of a cloud without labels (no
    class is noise then, withheld points are still left out)."""
    import copy

    from ..method.classes import UNLABELED

    pipe = copy.copy(pipeline)
    pipe.classes = UNLABELED
    return pipe


def _signature_of_set(folder, pipeline, execution, over=None):
    """The signature of a folder of LAS/LAZ tiles (or one LAS/LAZ file) processed as one set,
    with scratch files in a new folder inside the execution's ``work_dir`` or the temporary
    folder (``TMPDIR``), removed after the run, and whether its points are labelled; refuses an incomplete set. ``over``: the
    points of one file processed in tiles because of the memory budget (a note says so)."""
    from ..tiling.memory import exceed
    from ..tiling.run_set import run_set
    from ..tiling.work import discard_work, fresh_work

    work = fresh_work(execution.work_dir)
    try:
        with execution.backend() as backend:
            run = run_set(pipeline, [folder], work=work, tile_size=execution.tile_size, backend=backend,
                          memory=execution.memory)
    finally:
        discard_work(work)
    if not run.complete:
        raise LidarSigError("the set is incomplete, its signature would lack points: " + "; ".join(run.missing),
                            path=folder)
    if over:
        warnings.warn(f"{folder}: {exceed(over, int(execution.memory))}: processed in {counted(len(run.tile_stats), 'tile')}",
                      LidarSigWarning, stacklevel=3)
    run.signature.metadata["tiling"] = run.tiling_record()
    return run.signature, run.labelled
