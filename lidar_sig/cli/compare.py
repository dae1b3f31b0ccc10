"""`lidar-sig compare`: every metric between the signatures of two clouds or archives."""
import json

import click

from .group import cli
from .options import (check_report_outputs, columns_option, overwrite_option, pipeline_options, render_option,
                      report_options, tiling_options, write_report)
from .summaries import archive_summary_line, run_summary


@cli.command()
@click.argument("a")
@click.argument("b")
@click.option("--json", "as_json", is_flag=True, help="Print one JSON object on stdout.")
@report_options
@render_option
@overwrite_option
@columns_option
@tiling_options
@pipeline_options
def compare(a, b, as_json, report, plots, render, overwrite, columns, tiling, pipeline, method_given, quiet):
    """Compare the signatures of A and B (point-cloud files, signature archives or folders of
    LAS/LAZ tiles, each folder one epoch processed in tiles; in any mix).

    Both are made the same way: two clouds with the same method; a cloud compared with an
    archive the archive's way; two archives must record the same method.
    """
    if report or plots:
        from ..reporting import COMPARISON_PLOTS

        check_report_outputs(report, plots, COMPARISON_PLOTS, overwrite)
    from ..comparison import compare_sources
    from ..metrics import METRICS

    result = compare_sources(a, b, pipeline, render=render, columns=columns, method_given=method_given,
                             tiling=tiling)
    written = write_report(result.report(), report, plots, overwrite) if report or plots else []
    for note in result.warnings:
        click.echo(f"lidar-sig: warning: {note}", err=True)
    if as_json:
        click.echo(json.dumps(result.to_dict()))
        return
    for label, side in (("A", result.a), ("B", result.b)):
        line = run_summary(side.name, side.result) if side.result is not None else archive_summary_line(side)
        click.echo(f"{label} {line}")
    click.echo(f"  rendering {result.render}")
    click.echo("")
    for m in METRICS:
        value = result.metrics[m.key]
        shown = "n/a" if value is None else f"{value:.4f}"
        click.echo(f"  {m.name:<11} {shown:>8}   {m.short}, {m.same:g} = same")
    if not quiet:
        for line in written:
            click.echo(line)
