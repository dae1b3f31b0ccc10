"""Printing of run summaries shared by the commands."""
import json

import click

from ..base.errors import counted, printable


def say(line=""):
    """Print one line of a command's output on stdout as one line, whatever the file, tile or
    class names it shows hold (:func:`printable`: a name with a line break cannot forge a row)."""
    click.echo(printable(line))


def archive_summary_line(side):
    """One line for an archive input of compare."""
    from ..reporting.sections import scales_text

    m = side.signature.metadata
    scales = scales_text(m) if "resolved_scales" in m and "scale_kind" in m else m.get("scales", "?")
    what = "set of tiles" if "tiling" in m else "archive"
    return (f"{side.name}: {what} of {counted(side.signature.n_points, 'point')}, {m.get('descriptor', '?')} "
            f"{m.get('strategy', '?')}, {scales}, {m.get('weights', 'none')} weights")


def show(done, *, quiet=False, as_json=False):
    """Print what a job did (a :class:`lidar_sig.jobs._common.JobRun`): its JSON object with
    ``--json``, else its lines unless ``--quiet``; an incomplete run's problems on stderr, then
    exit status 1. Each line is one line whatever the file names it shows (:func:`printable`)."""
    if as_json:
        click.echo(json.dumps(done.to_dict()))
    elif not quiet:
        for line in done.lines:
            click.echo(printable(line))
    if not done.complete:
        for line in done.problems():
            click.echo(f"lidar-sig: {printable(line)}", err=True)
        raise click.exceptions.Exit(1)
