"""A survey catalogue made or grown (``lidar-sig catalog``; docs/commands/catalog.md)."""
from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from ..base.errors import counted, yes_no
from ._common import JobRun, PathLike, Sources

if TYPE_CHECKING:
    from ..pipeline.flow import Pipeline
    from ..survey_catalog import CatalogRun
    from ..tiling.execution import Execution


@dataclass(repr=False)
class CatalogJob(JobRun):
    """What :func:`catalog` did (:class:`JobRun`), with the catalogue's own account
    (:class:`~lidar_sig.survey_catalog._build.CatalogRun`: tiles added, recomputed, unchanged, failed)."""

    run: CatalogRun | None = None

    def to_dict(self) -> dict[str, Any]:
        r = self.run
        if r is None:
            return super().to_dict()
        return {**super().to_dict(), "catalogue": r.output, "tiles": r.n_tiles, "added": list(r.added),
                "updated": list(r.updated), "unchanged": list(r.unchanged), "resumed": list(r.resumed),
                "failed": dict(r.failed), "method": r.method, "crs": list(r.crs), "execution": r.execution}

    def problems(self) -> list[str]:
        if self.complete:
            return []
        from ..base.errors import arg

        return [f"missing: {line}" for line in self.missing] + [
            f"the catalogue lacks the {counted(len(self.missing), 'tile')} above: fix or replace them and run the "
            f"same job again (with {arg('resume', True)} the tiles finished in the work folder are reused)"]


def catalog(inputs: Sources, output: PathLike, *, pipeline: Pipeline | None = None,
            execution: Execution | None = None, resume: bool = False, overwrite: bool = False,
            method_given: Iterable[str] | None = None) -> CatalogJob:
    """Make the catalogue ``output`` (.h5) of the LAS/LAZ tiles of ``inputs``, or grow it
    (:func:`lidar_sig.survey_catalog.build_catalog`), on the workers or cluster of ``execution``, its
    work folder the execution's ``work_dir`` (default ``OUTPUT.work``)."""
    from ..survey_catalog import build_catalog
    from ..method.crs import crs_name
    from ..reporting.sections import scales_text
    from ..tiling.execution import as_execution

    resume = yes_no(resume, "resume")
    execution = as_execution(execution)
    with execution.backend() as backend:
        run = build_catalog(inputs, output, pipeline, backend=backend, work=execution.work_dir, resume=resume,
                            overwrite=overwrite, method_given=method_given)
    lines = []
    if run.n_tiles:
        what = [f"{len(run.added)} added"] if run.added or not run.grown else []
        what += [f"{len(run.updated)} recomputed (changed)"] if run.updated else []
        what += [f"{len(run.unchanged)} unchanged"] if run.unchanged else []
        what += [f"{len(run.resumed)} reused from the work folder"] if run.resumed else []
        m = run.method
        crs = [crs_name(c) or "none" for c in run.crs]
        where = f"CRS {crs[0]}" if len(crs) == 1 else f"{len(crs)} CRSs ({', '.join(crs)}): neighbours are found within each"
        lines = [f"{output}: {run.n_tiles:,} tile{'s' if run.n_tiles != 1 else ''} ({', '.join(what)}), "
                 f"{m['descriptor']} {m['strategy']}, {scales_text(m)}, {m['weights']} weights; {where}",
                 f"{run.execution}: {run.seconds:.1f} s"]
    return CatalogJob(written=[str(output)] if run.n_tiles else [], missing=run.missing, seconds=run.seconds,
                      lines=lines, run=run)


@dataclass(repr=False)
class OutliersRun(JobRun):
    """What :func:`outliers` did (:class:`JobRun`), with the tiles' scores
    (:class:`~lidar_sig.survey_catalog._outlier_scores.Outliers`)."""

    found: Any = None

    def to_dict(self) -> dict[str, Any]:
        return {**self.found.to_dict(), "written": list(self.written)}


def outliers(catalogue: PathLike, *, output: PathLike | None = None, report: PathLike | None = None,
             reach: float | None = None, overwrite: bool = False) -> OutliersRun:
    """Every tile of ``catalogue`` scored by how unlike it is to its neighbours and the survey
    (:meth:`lidar_sig.Catalog.outliers`), the footprints written as the GeoPackage ``output`` and
    the review page as ``report``: both checked before any work, written together or not at all."""
    from ..survey_catalog import Catalog
    from ..io import check_outputs, output_group
    from ..io.formats import VECTOR, check_format
    from ..reporting import check_report_path

    if output:
        check_format(output, VECTOR, said="the footprints")
    check_outputs([p for p in (output, report) if p], overwrite=overwrite)  # before any work
    if report:
        check_report_path(report, overwrite=overwrite)
    found = Catalog(catalogue).outliers(reach=reach)
    with output_group():  # all outputs or none
        if output:
            found.write_geopackage(output, overwrite=overwrite)
        if report:
            found.report().save(report, overwrite=overwrite)
    written = [str(p) for p in (output, report) if p]
    return OutliersRun(found=found, written=written, lines=[f"wrote {p}" for p in written])
