"""`lidar-sig signature`: the signature of a cloud, as an HDF5 archive, PNG images or a report."""
from pathlib import Path

import click

from ..errors import LidarSigError
from ..io import HDF5_EXTENSIONS, check_outputs, output_group, read
from .group import cli
from .options import (check_report_outputs, columns_option, not_empty, overwrite_option, pipeline_options,
                      render_option, renderings, report_options, resume_options, tiling_options, write_report)
from .summaries import echo_run
from .tiles import check_complete, exceed, finish, is_set, over_budget, run_tiles, scratch


@cli.command()
@click.argument("sources", nargs=-1, required=True)
@click.option("-o", "--output", default=None,
              help="Signature archive (.h5) or image of the augmented semantic signature Sas (.png).")
@click.option("--png", "png_output", default=None, callback=not_empty("a file name"),
              help="Also write Sas as PNG (with an .h5 output).")
@click.option("--sg", "sg_output", default=None, callback=not_empty("a file name"),
              help="Also write the geometric signature Sg as PNG.")
@click.option("--no-points", is_flag=True, help="Leave the per-point datasets out of the archive.")
@report_options
@render_option
@overwrite_option
@columns_option
@tiling_options
@resume_options
@pipeline_options
def signature(sources, output, png_output, sg_output, no_points, report, plots, render, overwrite, columns,
              tiling, resume, work_dir, pipeline, method_given, quiet):
    """Compute the signature of SOURCES; write it as an archive (.h5), images (.png) and/or an
    HTML report (--report).

    One file is processed as one block, or in tiles with halos when one block would need more
    memory than --memory. Several files, folders of LAS/LAZ tiles, or any of --tile-size,
    --workers, --scheduler make a set processed in tiles: its signature is the sum of the
    tiles' (the same as one block), and the archive records the tiling and every file with its
    SHA-256 (no per-point datasets).
    """
    tiled = is_set(sources, tiling, resume)
    over = None if tiled else over_budget(sources[0], tiling, pipeline)
    if over and (report or plots):
        raise LidarSigError(f"{exceed(over, tiling)}; --report and --plots need the whole cloud in memory: raise "
                            "--memory, or write the archive (-o FILE.h5)", path=sources[0])
    if tiled and (report or plots):
        raise LidarSigError("--report and --plots are made from one cloud; for a set of tiles write the "
                            "archive (-o set.h5) and compare it")
    if output is None and not (report or plots):
        raise LidarSigError("give an output: -o FILE.h5 or FILE.png, and/or --report FILE.html or --plots DIR")
    ext = Path(output).suffix.lower() if output else None
    if output and ext not in HDF5_EXTENSIONS + (".png",):
        raise LidarSigError("the signature is written as .h5 (archive) or .png (image)", path=output)
    images = [p for p in (png_output, sg_output) if p]
    for path in images:
        if Path(path).suffix.lower() != ".png":
            raise LidarSigError("signature images are written as .png", path=path)
    outputs = ([output] if output else []) + images
    check_outputs(outputs + ([report] if report else []), overwrite=overwrite)  # all of them, before any work
    if report or plots:
        from ..reporting import SIGNATURE_PLOTS

        check_report_outputs(report, plots, SIGNATURE_PLOTS, overwrite)
    render = render or renderings()[0]
    if tiled or over:
        return _signature_of_set(sources, output, ext, png_output, sg_output, render, overwrite, tiling, resume,
                                 work_dir, pipeline, quiet, over)
    from ..comparison import report as ls_report
    from ..io.png import write_signature_png

    source = sources[0]
    result = pipeline.run(read(source, columns=columns))
    written = []
    with output_group():  # all outputs or none
        if ext == ".png":
            write_signature_png(output, result.signature, kind="sas", mode=render, overwrite=overwrite)
        elif output:
            result.write(output, overwrite=overwrite, points=not no_points, render=render)
        if png_output:
            write_signature_png(png_output, result.signature, kind="sas", mode=render, overwrite=overwrite)
        if sg_output:
            write_signature_png(sg_output, result.signature, kind="sg", mode=render, overwrite=overwrite)
        if report or plots:
            written = write_report(ls_report(result, render=render), report, plots, overwrite)
    if not quiet:
        echo_run(source, result)
        if outputs:
            click.echo(f"wrote {', '.join(outputs)}")
        for line in written:
            click.echo(line)


def _signature_of_set(sources, output, ext, png_output, sg_output, render, overwrite, tiling, resume, work_dir,
                      pipeline, quiet, over=None):
    """A set's signature; ``over``: the points of one file processed in tiles because of the
    memory budget (its work folder is temporary, and a missing point is an error)."""
    first = output or png_output or sg_output
    outputs = [p for p in (output, png_output, sg_output) if p]
    if over:
        with scratch(first, work_dir) as work:
            run = run_tiles(pipeline, sources, tiling, work, outputs=outputs, quiet=quiet, over=over)
            check_complete(run, sources[0])
            _write_set_outputs(run, output, ext, png_output, sg_output, render, overwrite, quiet)
        return
    work = Path(work_dir) if work_dir else Path(first).with_name(Path(first).name + ".work")
    run = run_tiles(pipeline, sources, tiling, work, outputs=outputs, resume=resume, quiet=quiet)
    written = []
    if run.complete:
        written = _write_set_outputs(run, output, ext, png_output, sg_output, render, overwrite, quiet)
    finish(run, work, written, [] if run.complete else ["the set's signature (it would lack the points above)"])


def _write_set_outputs(run, output, ext, png_output, sg_output, render, overwrite, quiet):
    """Write the set's signature outputs, all or none; the paths written."""
    from ..io import write_archive
    from ..io.png import write_signature_png

    sig = run.signature
    with output_group():  # all outputs or none
        if ext == ".png":
            write_signature_png(output, sig, kind="sas", mode=render, overwrite=overwrite)
        elif output:
            write_archive(output, sig, sources=run.source_records(), render=render, overwrite=overwrite,
                          tiling=run.tiling_record())
        if png_output:
            write_signature_png(png_output, sig, kind="sas", mode=render, overwrite=overwrite)
        if sg_output:
            write_signature_png(sg_output, sig, kind="sg", mode=render, overwrite=overwrite)
    written = [p for p in (output, png_output, sg_output) if p]
    if not quiet:
        click.echo(f"wrote {', '.join(written)}")
    return written
