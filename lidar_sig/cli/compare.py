"""`lidar-sig compare`: every metric between the signatures of two clouds or archives."""
import json

import click

from ..base.errors import printable
from .options import (aoi_option, crs_option, columns_option, execution_options, json_option, overwrite_option, pipeline_options,
                      render_option, report_options)
from .summaries import archive_summary_line, say


@click.command()
@click.argument("a")
@click.argument("b")
@json_option
@report_options
@render_option
@overwrite_option
@columns_option
@crs_option
@execution_options(work_dir=False)
@aoi_option
@pipeline_options
def compare(a, b, as_json, report, plots, render, overwrite, columns, crs, execution, aoi, pipeline, method_given,
            quiet):
    """Compare the signatures of A and B (point-cloud files, signature archives or folders of
    LAS/LAZ tiles, each folder one epoch processed in tiles; in any mix).

    Both are made the same way: two clouds with the same method; a cloud compared with an
    archive the archive's way; two archives must record the same method.
    """
    from ..jobs import compare as compare_job
    from ..metrics import METRICS

    done = compare_job(a, b, report=report, plots=plots, overwrite=overwrite, crs=crs, pipeline=pipeline, render=render,
                       columns=columns, execution=execution, method_given=method_given, aoi=aoi)
    result = done.comparison
    for note in result.warnings:
        click.echo(printable(f"lidar-sig: warning: {note}"), err=True)
    if as_json:
        click.echo(json.dumps(done.to_dict()))
        return
    for label, side in (("A", result.a), ("B", result.b)):
        line = side.result.summary(side.name) if side.result is not None else archive_summary_line(side)
        say(f"{label} {line}")
    say(f"  rendering {result.render}")
    say("")
    for m in METRICS:
        value = result.metrics[m.key]
        shown = "n/a" if value is None else f"{value:.4f}"
        say(f"  {m.name:<11} {shown:>8}   {m.short}, {m.same:g} = same")
    if not quiet:
        for line in done.lines:
            say(line)
