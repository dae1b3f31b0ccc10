"""The signature of a cloud or a set, written as an archive, images and a report (``lidar-sig
signature``; docs/commands/signature.md).

One file is processed as one block, or in tiles when one block would exceed the memory budget;
several files, folders or tiles asked for make a set, whose signature is the sum of its tiles'.
Every output is checked before any work, and all of them are written, or none.
"""
from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ..base.errors import LidarSigError, arg, yes_no
from ..io import check_outputs, output_group, read
from ._common import Columns, JobRun, PathLike, Sources, as_sources, is_set, work_folder

if TYPE_CHECKING:
    from ..method.signature_raster import Signature
    from ..pipeline.flow import Pipeline
    from ..pipeline.result import Result
    from ..tiling.execution import Execution


@dataclass(repr=False)
class SignatureRun(JobRun):
    """What :func:`signature` did (:class:`JobRun`), with the signature made and, for one
    cloud, its Result."""

    signature: Signature | None = None
    result: Result | None = None

    def to_dict(self) -> dict[str, Any]:
        out = super().to_dict()
        if self.result is not None:
            out["run"] = self.result.to_dict()
        if self.signature is not None:
            out["signature"] = self.signature.summary()
        return out


def signature(sources: Sources, output: PathLike | None = None, *, png: PathLike | None = None,
              sg: PathLike | None = None, report: PathLike | None = None, plots: PathLike | None = None,
              points: bool = True, render: str | None = None, pipeline: Pipeline | None = None,
              execution: Execution | None = None, overwrite: bool = False, resume: bool = False,
              columns: Columns = None) -> SignatureRun:
    """Compute the signature of ``sources`` and write it: an archive (``output`` .h5) or an image
    of Sas (``output`` .png), Sas as PNG (``png``), Sg as PNG (``sg``), one cloud's HTML report
    (``report``) and its figures (``plots``, a folder).

    One file is one block, or tiles when one block would exceed the budget of ``execution``;
    several files, folders, or tiles asked for make a set processed in tiles, whose archive
    records the tiling and every file with its SHA-256 (no per-point datasets). ``points``:
    per-point datasets in the archive of one cloud run as one block. A report needs the whole
    cloud in memory. Other parameters as for :func:`lidar_sig.jobs.saliency`.
    """
    from ..pipeline.flow import pipeline_or_default
    from ..method.signature_raster import RENDERINGS
    from ..tiling.execution import as_execution

    resume = yes_no(resume, "resume")
    pipeline = pipeline_or_default(pipeline)
    execution = as_execution(execution)
    sources = as_sources(sources)
    as_set = is_set(sources, execution, resume)
    over = None if as_set else execution.over_budget(sources[0], pipeline)
    if over and (report or plots):
        from ..tiling.memory import exceed

        raise LidarSigError(f"{exceed(over, int(execution.memory))}; {arg('report')} and {arg('plots')} need the whole "
                            f"cloud in memory: raise {arg('memory')}, or write the archive", path=sources[0])
    if as_set and (report or plots):
        raise LidarSigError(f"{arg('report')} and {arg('plots')} are made from one cloud: give one file without "
                            f"{arg('tile_size')}, {arg('workers')} or {arg('scheduler')}; for a set of tiles write the "
                            "archive and compare it")
    ext, outputs = _checked_outputs(output, png, sg, report, plots, overwrite)
    render = render or RENDERINGS[0]
    start = time.perf_counter()
    if as_set and not over:
        return _of_set(sources, output, ext, png, sg, render, pipeline, execution, overwrite, resume, start)
    if over:
        from ..pipeline.flow import in_tiles
        from ..tiling.work import work_scope

        first = Path(outputs[0])
        work = work_folder(execution, first.with_name(f".{first.name}.lidar-sig-work"))
        with work_scope(work), in_tiles(pipeline, sources[0], execution, n_points=over, work=work,
                                        outputs=outputs) as tiled, output_group():  # all outputs or none
            _write(tiled.signature, output, ext, png, sg, render, overwrite, archive=tiled.write)
        return SignatureRun(written=outputs, signature=tiled.signature, result=tiled,
                            lines=tiled.summary_lines() + [f"wrote {', '.join(outputs)}"],
                            seconds=time.perf_counter() - start)
    result = pipeline.run(read(sources[0], columns=columns))
    lines = [result.summary(sources[0])] + ([f"wrote {', '.join(outputs)}"] if outputs else [])
    written = list(outputs)
    with output_group():  # all outputs or none
        _write(result.signature, output, ext, png, sg, render, overwrite,
               archive=lambda path, **kw: result.write(path, points=points, **kw))
        if report or plots:
            from ..comparison import report as make_report
            from ._reports import write_report

            more, said = write_report(lambda: make_report(result, render=render), report, plots, overwrite)
            written += more
            lines += said
    return SignatureRun(written=written, signature=result.signature, result=result, lines=lines,
                        seconds=time.perf_counter() - start)


def _checked_outputs(output: PathLike | None, png: PathLike | None, sg: PathLike | None, report: PathLike | None,
                     plots: PathLike | None, overwrite: bool) -> tuple[str | None, list[str]]:
    """Every output checked before any work: what ``output`` is ("archive", "image" or None) and
    the signature's files (``output``, ``png``, ``sg``)."""
    from ..io.formats import IMAGE, SIGNATURE, check_format, holds

    if output is None and not (report or plots):
        raise LidarSigError(f"give an output: an .h5 or .png file, and/or a {arg('report')} or {arg('plots')}")
    if output and not (holds(output, SIGNATURE) or holds(output, IMAGE)):
        raise LidarSigError("the signature is written as .h5 (archive) or .png (image)", path=output)
    ext = "image" if output and holds(output, IMAGE) else "archive" if output else None
    images = [p for p in (png, sg) if p]
    for path in images:
        check_format(path, IMAGE, said="a signature's image")
    outputs = [str(p) for p in ([output] if output else []) + images]
    check_outputs(outputs + ([str(report)] if report else []), overwrite=overwrite)  # all of them, before any work
    if report or plots:
        from ..reporting import SIGNATURE_PLOTS
        from ._reports import check_report_outputs

        check_report_outputs(report, plots, SIGNATURE_PLOTS, overwrite)
    return ext, outputs


def _write(sig: Signature, output: PathLike | None, ext: str | None, png: PathLike | None, sg: PathLike | None,
           render: str, overwrite: bool, *, archive: Callable[..., None]) -> None:
    """The signature's outputs (inside the caller's output group): ``archive(path, overwrite=,
    render=)`` writes the .h5 of the run."""
    from ..io.png import write_signature_png

    if ext == "image" and output:
        write_signature_png(output, sig, kind="sas", mode=render, overwrite=overwrite)
    elif output:
        archive(output, overwrite=overwrite, render=render)
    if png:
        write_signature_png(png, sig, kind="sas", mode=render, overwrite=overwrite)
    if sg:
        write_signature_png(sg, sig, kind="sg", mode=render, overwrite=overwrite)


def _of_set(sources: list[str], output: PathLike | None, ext: str | None, png: PathLike | None, sg: PathLike | None,
            render: str, pipeline: Pipeline, execution: Execution, overwrite: bool, resume: bool,
            start: float) -> SignatureRun:
    from ..io import write_archive
    from ..tiling.run_set import run_set
    from ..tiling.work import remove_work, work_scope

    outputs = [str(p) for p in (output, png, sg) if p]
    first = Path(outputs[0])
    work = work_folder(execution, first.with_name(first.name + ".work"))
    with work_scope(work):  # let go at the end; kept only with work worth resuming, which the result names
        with execution.backend() as backend:
            run = run_set(pipeline, sources, work=work, tile_size=execution.tile_size, backend=backend,
                          resume=resume, outputs=outputs, memory=execution.memory)
        job = SignatureRun(lines=run.summary(), missing=run.missing)
        if run.complete and run.signature is not None:
            sig = job.signature = run.signature
            with output_group():  # all outputs or none
                _write(sig, output, ext, png, sg, render, overwrite,
                       archive=lambda path, **kw: write_archive(path, sig, sources=run.source_records(),
                                                                tiling=run.tiling_record(), **kw))
            job.written = outputs
            job.lines.append(f"wrote {', '.join(outputs)}")
            remove_work(work)
        else:
            job.not_written = ["the set's signature (it would lack the points above)"]
    job.work = str(work) if not job.complete and Path(work).is_dir() else None  # kept for a resumed run
    job.seconds = time.perf_counter() - start
    return job
