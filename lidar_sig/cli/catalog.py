"""`lidar-sig catalog`: one signature per tile of a survey, in a catalogue made or grown."""
import click

from .group import cli
from .options import overwrite_option, pipeline_options, resume_options, scheduler_option, workers_option


@cli.command()
@click.argument("inputs", nargs=-1, required=True)
@click.option("-o", "--output", required=True, metavar="FILE.h5",
              help="The catalogue: made, or grown when it exists (tiles already in it, same path and SHA-256, "
                   "are not computed again).")
@overwrite_option
@workers_option
@scheduler_option
@resume_options
@pipeline_options
def catalog(inputs, output, overwrite, workers, scheduler, resume, work_dir, pipeline, method_given, quiet):
    """Compute the signature of every LAS/LAZ tile of INPUTS (files and folders) into a catalogue,
    for `lidar-sig similar` and `lidar-sig outliers`.

    Each tile's saliency is computed on the tile alone. An existing catalogue grows: new and
    changed files are computed, the others kept; it holds one method (method options that
    differ from its own are refused). --overwrite makes it anew.
    """
    from ..catalog import build_catalog
    from ..crs import crs_name
    from ..reporting.sections import scales_text
    from ..tiling.execute import executor

    backend = executor(workers, scheduler)
    try:
        run = build_catalog(inputs, output, pipeline, backend=backend, work=work_dir, resume=resume,
                            overwrite=overwrite, method_given=method_given)
    finally:
        backend.close()
    if not quiet and run.n_tiles:
        what = [f"{len(run.added)} added"] if run.added or not run.grown else []
        what += [f"{len(run.updated)} recomputed (changed)"] if run.updated else []
        what += [f"{len(run.unchanged)} unchanged"] if run.unchanged else []
        what += [f"{len(run.resumed)} reused from the work folder"] if run.resumed else []
        m = run.method
        crs = [crs_name(c) or "none" for c in run.crs]
        where = f"CRS {crs[0]}" if len(crs) == 1 else f"{len(crs)} CRSs ({', '.join(crs)}): neighbours are found within each"
        click.echo(f"{output}: {run.n_tiles:,} tile{'s' if run.n_tiles != 1 else ''} ({', '.join(what)}), "
                   f"{m['descriptor']} {m['strategy']}, {scales_text(m)}, {m['weights']} weights; {where}")
        click.echo(f"{run.execution}: {run.seconds:.1f} s")
    if not run.complete:
        for line in run.missing:
            click.echo(f"lidar-sig: missing: {line}", err=True)
        click.echo(f"lidar-sig: the catalogue lacks the {len(run.failed)} tile{'s' if len(run.failed) != 1 else ''} "
                   "above: fix or replace them and run the same command again (with --resume the tiles finished "
                   "in the work folder are reused)", err=True)
        raise click.exceptions.Exit(1)
