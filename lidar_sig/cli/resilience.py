"""`lidar-sig resilience`: how much each metric moves under random subsampling of one cloud."""
import json

import click

from ..base.errors import counted
from ..io import check_output, read
from .options import (Default, aoi_option, columns_option, not_empty, number_list, overwrite_option, pipeline_options,
                      render_option)
from .summaries import say


def _fractions():
    from ..jobs.resilience import DEFAULT_FRACTIONS

    return ",".join(f"{f:g}" for f in DEFAULT_FRACTIONS)


@click.command("resilience")
@click.argument("source")
@click.option("--fractions", type=str, default=Default(_fractions), show_default=True,
              help="Fractions of the points to keep, comma-separated, each in (0, 1].")
@click.option("--repeats", default=3, show_default=True, type=click.IntRange(1, 1000),
              help="Random subsamples per fraction.")
@click.option("--seed", default=0, show_default=True, type=click.IntRange(0),
              help="Seed of the random subsamples.")
@click.option("--json", "as_json", is_flag=True, help="Print one JSON object on stdout.")
@click.option("--plot", default=None, callback=not_empty("a file name"),
              help="Also draw every metric against the fraction as a PNG file.")
@render_option
@overwrite_option
@columns_option
@aoi_option
@pipeline_options
def resilience_command(source, fractions, repeats, seed, as_json, plot, render, overwrite, columns, aoi, pipeline,
                       method_given, quiet):
    """Compare SOURCE with uniform random subsamples of itself, fraction by fraction."""
    from ..metrics import METRIC_KEYS, METRIC_NAMES
    from ..jobs.resilience import check_fractions, plot_resilience, resilience

    values = check_fractions(number_list(fractions, "--fractions"), "--fractions")
    if plot:
        from ..io.formats import IMAGE, check_format

        check_format(plot, IMAGE, said="the plot")
        check_output(plot, overwrite=overwrite)
    result = resilience(read(source, columns=columns) if aoi is None else source, pipeline, aoi=aoi, fractions=values, repeats=repeats, seed=seed,
                        render=render or "smooth", progress=False if quiet else None)
    if plot:
        plot_resilience(result, plot, overwrite=overwrite)
    if as_json:
        click.echo(json.dumps(result.to_dict()))
        return
    keys = [k for k in METRIC_KEYS if result.to_dict()["metrics"][k] is not None]
    say(f"{source}: {counted(result.repeats, 'random subsample')} per fraction (seed {result.seed}), "
        f"{result.render} rendering; mean ± standard deviation against the full cloud")
    header = f"{'fraction':>8} {'points':>10} " + " ".join(f"{METRIC_NAMES[k]:>17}" for k in keys)
    say(header)
    stats = {k: result.summary(k) for k in keys}
    for i, (fraction, n) in enumerate(zip(result.fractions, result.points)):
        cells = " ".join(f"{stats[k][0][i]:>9.4f} ± {stats[k][1][i]:<6.4f}" for k in keys)
        say(f"{fraction:>8g} {n:>10,} {cells}")
    if plot and not quiet:
        say(f"wrote {plot}")
