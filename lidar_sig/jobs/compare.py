"""Two inputs compared, and the report written (``lidar-sig compare``; docs/commands/compare.md)."""
from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from ._common import Columns, JobRun, PathLike, reads_clouds

if TYPE_CHECKING:
    from ..comparison import Comparison
    from ..pipeline.flow import Pipeline
    from ..tiling.execution import Execution


@dataclass(repr=False)
class CompareRun(JobRun):
    """What :func:`compare` did (:class:`JobRun`): the :class:`~lidar_sig.comparison.Comparison`
    and the report files written."""

    comparison: Comparison | None = None

    def to_dict(self) -> dict[str, Any]:
        return {**(self.comparison.to_dict() if self.comparison is not None else {}), "written": list(self.written),
                **self.area_dict()}


@reads_clouds
def compare(a: Any, b: Any, *, report: PathLike | None = None, plots: PathLike | None = None, overwrite: bool = False,
            pipeline: Pipeline | None = None, render: str | None = None, columns: Columns = None,
            execution: Execution | None = None, method_given: Iterable[str] = (),
            crs: str | None = None, aoi: Any = None) -> CompareRun:
    """Compare ``a`` and ``b`` (:func:`lidar_sig.comparison.compare_sources`) and write the
    report (``report``, an .html file) and its figures (``plots``, a folder), checked before any
    work and written together or not at all. ``method_given``: the method options a user set,
    which an archive's recorded method must then agree with. ``aoi``: an area of interest both
    inputs are clipped to (:func:`lidar_sig.jobs.saliency`).
    ``crs``: the CRS of clouds whose header carries none (``--crs``; :func:`._common.reads_clouds`).
    """
    from ..comparison import compare_sources
    from ..io.clip import clip_inputs
    from ..reporting import COMPARISON_PLOTS
    from ._reports import check_report_outputs, write_report

    check_report_outputs(report, plots, COMPARISON_PLOTS, overwrite)
    with clip_inputs([a, b], aoi) as clip:
        clipped_a, clipped_b = clip.inputs
        comparison = compare_sources(clipped_a, clipped_b, pipeline, render=render, columns=columns,
                                     method_given=method_given, execution=execution)
        written, lines = write_report(comparison.report, report, plots, overwrite) if report or plots else ([], [])
    return CompareRun(comparison=comparison, written=written, lines=lines).with_reading(clip)
