"""The per-point saliency of files, written (``lidar-sig saliency``; docs/commands/saliency.md).

One file gives one output (LAS/LAZ extra dimensions, PLY/PCD attributes, text columns), as one
block or, when one block would exceed the memory budget, in tiles streamed into the one LAS/LAZ
file named; several files, folders or tiles asked for make a set processed in tiles, with one
LAS/LAZ output per input file in an output folder. Outputs are checked before any work and
written whole or not at all.
"""
from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ..base.errors import LidarSigError, arg, as_path, yes_no
from ..io import CLOUD_EXTENSIONS, check_cloud_output, check_output, read
from ..io.formats import POINTS, format_of, holds
from ..io.tile_lists import check_apart
from ._common import Columns, JobRun, PathLike, Sources, as_sources, is_set, work_folder

if TYPE_CHECKING:
    from ..pipeline.flow import Pipeline
    from ..pipeline.result import Result
    from ..tiling.execution import Execution


@dataclass(repr=False)
class SaliencyRun(JobRun):
    """What :func:`saliency` did (:class:`JobRun`), with the Result of one file (None for a
    set; a closed :class:`~lidar_sig.pipeline.result.TiledResult` for one run in tiles)."""

    result: Result | None = None

    def to_dict(self) -> dict[str, Any]:
        out = super().to_dict()
        if self.result is not None:
            out["run"] = self.result.to_dict()
        return out


def saliency(sources: Sources, output: PathLike, *, pipeline: Pipeline | None = None,
             execution: Execution | None = None, overwrite: bool = False, resume: bool = False,
             columns: Columns = None) -> SaliencyRun:
    """Write each of ``sources`` with its per-point Cl, Cs, Cp, Egeom, GeomClass (and
    OptimalScale) to ``output``.

    Parameters
    ----------
    sources : path or list of paths
        One point-cloud file (LAS/LAZ, PLY/PCD, text), or LAS/LAZ files and folders of them
        processed as one set in tiles with halos (the same results as one block).
    output : path
        For one file: a point cloud (its format by extension). For a set: a folder that gets
        one LAS/LAZ file per input (or, for one input file, a LAS/LAZ file).
    pipeline : Pipeline, optional
        The method; default ``Pipeline()``.
    execution : Execution, optional
        Memory budget, tiles, workers, work folder (default: 1 GiB per process, all cores, the
        work folder beside the output).
    overwrite, resume
        Replace existing outputs; reuse what an earlier run of the same set finished in its
        work folder (kept after a failure).
    columns : str or list, optional
        Columns of a text cloud.
    """
    from ..pipeline.flow import pipeline_or_default
    from ..tiling.execution import as_execution

    resume = yes_no(resume, "resume")
    pipeline = pipeline_or_default(pipeline)
    execution = as_execution(execution)
    sources = as_sources(sources)
    output = as_path(output, "saliency's output")
    one_output = len(sources) == 1 and Path(sources[0]).is_file() and holds(output, POINTS)  # one file in, one out
    if resume and one_output:
        raise LidarSigError(f"{arg('resume', True)} continues a set's run from its kept work folder, and one file in "
                            f"tiles keeps none (it starts over); leave out {arg('resume', True)}, or give a folder as "
                            "output to run the file as a set", path=output)
    if is_set(sources, execution, resume) and not one_output:
        return _of_set(sources, output, pipeline, execution, overwrite, resume)
    source = sources[0]
    if not holds(output, POINTS):
        raise LidarSigError(f"output must be a point cloud: {', '.join(CLOUD_EXTENSIONS)}", path=output)
    check_output(output, overwrite=overwrite)
    check_apart([output], [source])
    start = time.perf_counter()
    over = execution.over_budget(source, pipeline)
    result: Result
    if over or execution.tiles_asked:
        from ..pipeline.flow import in_tiles
        from ..tiling.work import work_scope

        check_las_output(output, over, execution)
        work = work_folder(execution, output.with_name(f".{output.name}.lidar-sig-work"))
        with work_scope(work), in_tiles(pipeline, source, execution, n_points=over, work=work,
                                        outputs=[output]) as tiled:
            tiled.write(output, overwrite=overwrite)
        result = tiled
        lines = tiled.summary_lines()
    else:
        cloud = read(source, columns=columns)
        check_cloud_output(output, cloud)  # before the work, not after
        result = pipeline.run(cloud)
        result.write(output, overwrite=overwrite)
        lines = [result.summary(source)]
    seconds = time.perf_counter() - start
    return SaliencyRun(written=[str(output)], seconds=seconds, result=result,
                       lines=lines + [f"wrote {output} in {seconds:.1f} s"])


def check_las_output(output: Path, over: int | None, execution: Execution) -> None:
    """Refuse a per-point output other than LAS/LAZ for a file processed in tiles."""
    from ..base.errors import arg
    from ..tiling.memory import exceed

    fmt = format_of(output)
    if fmt is None or not fmt.streamed:
        what = f"{exceed(over, int(execution.memory))}; tiles" if over else "a file processed in tiles: tiles"
        fix = f"raise {arg('memory')}" if over else f"leave out {arg('tile_size')}, {arg('workers')} and {arg('scheduler')}"
        raise LidarSigError(f"{what} stream per-point results to LAS/LAZ only: give a .las or .laz name, or {fix}",
                            path=output)


def output_name(outdir: Path, source: Any) -> Path:
    """Per-point output of one input file of a set: its name, in ``outdir`` (LAS stays LAS,
    LAZ LAZ)."""
    p = Path(source.path)
    fmt = format_of(p)
    return outdir / (p.name if fmt is not None and fmt.streamed else p.stem + ".laz")


def _of_set(sources: list[str], outdir: Path, pipeline: Pipeline, execution: Execution, overwrite: bool,
            resume: bool) -> SaliencyRun:
    from ..tiling.sources import expand, scan

    start = time.perf_counter()
    files = expand(sources)  # the inputs first: an empty folder is named, not the output
    if holds(outdir, POINTS) or (outdir.exists() and not outdir.is_dir()):
        raise LidarSigError("a set of tiles writes one file per input: give a folder as output", path=outdir)
    outputs = {s.path: output_name(outdir, s) for s in scan(files)}
    inputs = {Path(p).resolve(): p for p in outputs}
    seen: dict[Path, str] = {}
    for src, path in outputs.items():
        if Path(path).resolve() in inputs:  # an input is never replaced
            raise LidarSigError(f"would be written over its input {src}; give another output folder", path=path)
        if path in seen:
            raise LidarSigError(f"would be written for both {seen[path]} and {src} (same file name); give "
                                "them in separate runs", path=path)
        seen[path] = src
    if not outdir.parent.is_dir():
        raise LidarSigError("the output folder's parent does not exist; create it first", path=outdir)
    made = make_folder(outdir)
    work = work_folder(execution, outdir / ".lidar-sig-work")
    try:
        job = _write_set(sources, outputs, work, pipeline, execution, overwrite, resume)
    finally:  # a folder made for this run and left empty (an error, or nothing written) goes
        if made and outdir.is_dir() and not any(outdir.iterdir()):
            outdir.rmdir()
    job.seconds = time.perf_counter() - start
    return job


def _write_set(sources: list[str], outputs: dict[str, Path], work: Path, pipeline: Pipeline, execution: Execution,
               overwrite: bool, resume: bool) -> SaliencyRun:
    """The set run in tiles and each input's output written, within the scope of the work folder
    (let go at the end; kept only with work worth resuming, which the job's result names)."""
    from ..tiling.run_set import run_set
    from ..tiling.work import remove_work, work_scope

    with work_scope(work):
        for path in outputs.values():  # before the work; a resumed run rewrites what it must
            check_output(path, overwrite=overwrite or resume)
        with execution.backend() as backend:
            run = run_set(pipeline, sources, work=work, tile_size=execution.tile_size, backend=backend,
                          resume=resume, outputs=list(outputs.values()), memory=execution.memory)
        job = SaliencyRun(lines=run.summary())
        for source in run.sources:
            if source.path in run.failed_sources or run.plan is None:
                continue
            if run.write_points(source, outputs[source.path], overwrite=overwrite or resume):
                job.written.append(str(outputs[source.path]))
            else:
                job.not_written.append(f"{outputs[source.path]} (a tile holding some of its points is missing)")
        job.missing = run.missing
        job.lines += [f"wrote {path}" for path in job.written]
        if job.complete:
            remove_work(work)
    job.work = str(work) if not job.complete and Path(work).is_dir() else None  # kept for a resumed run
    return job


def make_folder(folder: Path) -> bool:
    """Make the output folder ``folder`` (its parent exists); True when it was made now. A
    folder that cannot be made is a LidarSigError naming it and the fix."""
    from ..io.atomic import os_errors

    if folder.is_dir():
        return False
    with os_errors(folder):
        folder.mkdir()
    return True
