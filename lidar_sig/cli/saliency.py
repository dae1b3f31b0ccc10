"""`lidar-sig saliency`: per-point saliency written as LAS/LAZ extra dimensions."""
import time
from pathlib import Path

import click

from ..errors import LidarSigError
from ..io import CLOUD_EXTENSIONS, check_cloud_output, check_output, read
from .group import cli
from .options import columns_option, overwrite_option, pipeline_options, resume_options, tiling_options
from .summaries import echo_run
from .tiles import (check_complete, check_las_output, finish, is_set, output_name, over_budget, run_tiles,
                    scratch)


@cli.command()
@click.argument("sources", nargs=-1, required=True)
@click.option("-o", "--output", required=True,
              help="Output point cloud: LAS/LAZ (extra dimensions), PLY/PCD (attributes) or text (columns); "
                   "for a set of tiles, a folder that gets one LAS/LAZ per input file.")
@overwrite_option
@columns_option
@tiling_options
@resume_options
@pipeline_options
def saliency(sources, output, overwrite, columns, tiling, resume, work_dir, pipeline, method_given, quiet):
    """Write SOURCES with per-point Cl, Cs, Cp, Egeom, GeomClass (and OptimalScale).

    One file is processed as one block, or in tiles with halos when one block would need more
    memory than --memory (the same results; OUTPUT is then LAS/LAZ). Several files, folders of
    LAS/LAZ tiles, or any of --tile-size, --workers, --scheduler make a set processed in tiles
    (the same results as one block); OUTPUT is then a folder, or for one input file a LAS/LAZ
    file.
    """
    one_output = (len(sources) == 1 and Path(sources[0]).is_file() and not resume
                  and Path(output).suffix.lower() in CLOUD_EXTENSIONS)  # one file in, one file out
    if is_set(sources, tiling, resume) and not one_output:
        return _saliency_of_set(sources, output, overwrite, tiling, resume, work_dir, pipeline, quiet)
    source = sources[0]
    if Path(output).suffix.lower() not in CLOUD_EXTENSIONS:
        raise LidarSigError(f"output must be a point cloud: {', '.join(CLOUD_EXTENSIONS)}", path=output)
    check_output(output, overwrite=overwrite)
    over = over_budget(source, tiling, pipeline)
    if over or is_set(sources, tiling):
        return _saliency_in_tiles(source, output, over, overwrite, tiling, work_dir, pipeline, quiet)
    start = time.perf_counter()
    cloud = read(source, columns=columns)
    check_cloud_output(output, cloud)  # before the work, not after
    result = pipeline.run(cloud)
    result.write(output, overwrite=overwrite)
    if not quiet:
        echo_run(source, result)
        click.echo(f"wrote {output} in {time.perf_counter() - start:.1f} s")


def _saliency_in_tiles(source, output, over, overwrite, tiling, work_dir, pipeline, quiet):
    """One file processed in tiles (over the memory budget, or as the tiling options ask),
    streamed into the one LAS/LAZ output; the work folder is temporary."""
    check_las_output(output, over, tiling)
    start = time.perf_counter()
    with scratch(output, work_dir) as work:
        run = run_tiles(pipeline, [source], tiling, work, outputs=[output], quiet=quiet, over=over)
        check_complete(run, source)
        run.write_points(run.sources[0], output, overwrite=overwrite)
    if not quiet:
        click.echo(f"wrote {output} in {time.perf_counter() - start:.1f} s")


def _saliency_of_set(sources, output, overwrite, tiling, resume, work_dir, pipeline, quiet):
    from ..tiling.sources import expand, scan

    files = expand(sources)  # the inputs first: an empty folder is named, not the output
    outdir = Path(output)
    if outdir.suffix.lower() in CLOUD_EXTENSIONS or (outdir.exists() and not outdir.is_dir()):
        raise LidarSigError("a set of tiles writes one file per input: give a folder as -o", path=output)
    outputs = {s.path: output_name(outdir, s) for s in scan(files)}
    inputs = {Path(p).resolve(): p for p in outputs}
    seen = {}
    for src, path in outputs.items():
        if Path(path).resolve() in inputs:  # an input is never replaced
            raise LidarSigError(f"would be written over its input {src}; give another output folder", path=path)
        if path in seen:
            raise LidarSigError(f"would be written for both {seen[path]} and {src} (same file name); give "
                                "them in separate runs", path=path)
        seen[path] = src
    if not outdir.parent.is_dir():
        raise LidarSigError("the output folder's parent does not exist; create it first", path=output)
    made = not outdir.exists()
    outdir.mkdir(exist_ok=True)
    work = Path(work_dir) if work_dir else outdir / ".lidar-sig-work"
    try:
        for path in outputs.values():  # before the work; --resume rewrites what it must
            check_output(path, overwrite=overwrite or resume)
        run = run_tiles(pipeline, sources, tiling, work, outputs=list(outputs.values()), resume=resume,
                        quiet=quiet)
    except LidarSigError:
        if made and not any(outdir.iterdir()):
            outdir.rmdir()
        raise
    written, not_written = [], []
    for source in run.sources:
        if source.path in run.failed_sources or run.plan is None:
            continue
        if run.write_points(source, outputs[source.path], overwrite=overwrite or resume):
            written.append(str(outputs[source.path]))
        else:
            not_written.append(f"{outputs[source.path]} (a tile holding some of its points is missing)")
    if not quiet:
        for path in written:
            click.echo(f"wrote {path}")
    finish(run, work, written, not_written)
