"""Two sides compared (:class:`Comparison`): the metrics between their signatures, what may make
the figures mislead, and the report (compute, then report)."""
from __future__ import annotations

import os
from collections.abc import Iterable, Sequence
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ..base.errors import LidarSigError, arg, as_path
from ..base.progress import step
from ..metrics import compare as compare_signatures
from ..method.class_maps import class_scheme_warnings
from ..method.cloud import PointCloud
from ..method.scales import ScaleKind, recorded_kind, recorded_scales
from ..method.signature_raster import RENDERINGS, Signature, method_differences
from ._sides import (Side, archive_pipeline, holds_signature, input_name, load_input, side_of, signature_of_set,
                     unlabelled_pipeline)

if TYPE_CHECKING:
    from ..pipeline.flow import Pipeline
    from ..reporting import Report
    from ..tiling.execution import Execution

#: Share of a cloud's points with undefined saliency above which compare warns.
UNDEFINED_WARNING = 0.05
#: Normalized radii resolving to metric radii further apart than this get a warning.
RADII_TOLERANCE = 0.10


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
        self.reading: Any = None  # what was read when the inputs were clipped (lidar_sig.io.clip.Reading)

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


def compare(a: Any, b: Any, *, pipeline: Pipeline | None = None, render: str | None = None,
            columns: str | Sequence[str] | None = None, execution: Execution | None = None,
            color_bins: int = 8, aoi: Any = None) -> Comparison:
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
    aoi : str, path or tuple, optional
        An area of interest both inputs are clipped to (see :func:`compare_sources`).

    >>> import lidar_sig as ls                                                    # doctest: +SKIP
    >>> ls.compare("epoch1.laz", "epoch2.laz")["l1"]                              # doctest: +SKIP
    0.1558...
    """
    # a pipeline given is the whole method the caller means: an archive made otherwise is refused
    given = ("pipeline",) if pipeline is not None else ()
    return compare_sources(a, b, pipeline, render=render, columns=columns, execution=execution,
                           color_bins=color_bins, method_given=given, aoi=aoi)


def metric_scales(values):
    """{metric key: :meth:`lidar_sig.metrics.Metric.scale`} of the metrics that have a value."""
    from ..metrics import METRICS

    return {m.key: m.scale(values[m.key]) for m in METRICS if values.get(m.key) is not None}


def report(a: Any, b: Any = None, pipeline: Pipeline | None = None, *, render: str | None = None,
           columns: str | Sequence[str] | None = None) -> Report:
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


def compare_sources(a: Any, b: Any, pipeline: Pipeline | None = None, *, render: str | None = None,
                    columns: str | Sequence[str] | None = None, method_given: Iterable[str] = (),
                    execution: Execution | None = None, color_bins: int = 8, aoi: Any = None) -> Comparison:
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
    aoi : str, path or tuple, optional
        An area of interest: bounds ``"XMIN,YMIN,XMAX,YMAX"`` (or four numbers) in the clouds'
        CRS, or a GeoPackage or GeoJSON polygon file in any CRS; both inputs (LAS/LAZ/COPC files,
        folders, .vpc, URLs) are clipped to it first, reading only what it needs (the
        comparison's ``reading`` says what was read).
    """
    from ..pipeline.flow import pipeline_or_default

    from ..io.clip import clip_inputs

    clip = clip_inputs([a, b], aoi)  # clipped to the area, or fetched from a web server
    if clip.reading is not None:
        with clip:
            clipped_a, clipped_b = clip.inputs
            compared = compare_sources(clipped_a, clipped_b, pipeline, render=render, columns=columns,
                                       method_given=method_given, execution=execution, color_bins=color_bins)
        compared.reading = clip.reading
        return compared
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
    loaded = [load_input(x, what=what) if holds_signature(x) else x for x, what in zip((a, b), "ab")]
    sigs = [x for x in loaded if isinstance(x, Signature)]
    if sigs:
        reference = sigs[0]
        pipeline = archive_pipeline(reference, pipeline, method_given, names[loaded.index(reference)])
    over = [None if as_set else execution.over_budget(x, pipeline) for x in loaded]
    loaded = [load_input(x, columns, as_set or bool(n), what) for x, n, what in zip(loaded, over, "ab")]
    sides, notes = _computed(a, b, names, loaded, over, pipeline, execution)
    first, second = sides[0].signature, sides[1].signature
    differ = method_differences(first.metadata, second.metadata)
    if differ:
        raise LidarSigError(f"{names[0]} and {names[1]} were made with different methods ("
                            + "; ".join(differ) + "); make both with the same settings")
    render = render or recorded_render(sides)
    with step("metrics", rendering=render):
        metrics = compare_signatures(first, second, render=render, color_bins=color_bins)
    notes += undefined_warnings(sides) + class_warnings(sides) + radii_warnings(sides)
    method = {k: first.metadata[k] for k in ("descriptor", "descriptor_params", "strategy", "scale_kind",
                                             "scale_values", "scale_units", "weights", "keep_noise")
              if k in first.metadata}
    return Comparison(sides[0], sides[1], metrics, render, method, notes)


def _computed(a: Any, b: Any, names: list[str], loaded: list[Any], over: list[int | None], pipeline: Pipeline,
              execution: Execution) -> tuple[list[Side], list[str]]:
    """The two sides with their signatures made with one method: an archive's as it is, a cloud
    run through ``pipeline``, a set (a folder, or a file ``over`` the memory budget) in tiles; and
    the notes. With one side unlabelled every cloud is one class, so that both stay comparable."""
    from ..pipeline.result import Result

    sigs = [x for x in loaded if isinstance(x, Signature)]
    # a set's labels are known once it is run: with an unlabelled cloud or archive on the other
    # side, it is run without them straight away (see geometry_only below)
    unlabelled = (any(not x.classes.names for x in sigs)
                  or any(isinstance(x, PointCloud) and x.labels is None for x in loaded))
    sets = {i: signature_of_set(x, unlabelled_pipeline(pipeline) if unlabelled else pipeline, execution,
                                over=over[i])
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
                sets[i] = signature_of_set(loaded[i], unlabelled_pipeline(pipeline), execution, over=over[i])
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
    return sides, notes


def recorded_render(sides: list[Side]) -> str:
    recorded = {str(s.signature.metadata["render"]) for s in sides
                if s.kind in ("archive", "signature") and "render" in s.signature.metadata}
    if len(recorded) > 1:
        raise LidarSigError(f"the archives were rendered differently ({', '.join(sorted(recorded))}); give "
                            f"{arg('render')} ({', '.join(RENDERINGS)}) to compare both under one rendering")
    return recorded.pop() if recorded else RENDERINGS[0]


def undefined_warnings(sides: list[Side]) -> list[str]:
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


def class_warnings(sides: list[Side]) -> list[str]:
    """Warn when a cloud's points are largely in classes the other cloud does not use."""
    a, b = (s.signature for s in sides)
    if not a.classes.names:
        return []
    return class_scheme_warnings(a.class_totals, b.class_totals, a.classes.class_names, [s.name for s in sides])


def radii_warnings(sides: list[Side]) -> list[str]:
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
