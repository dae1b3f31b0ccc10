"""Printing of run summaries shared by the commands."""
import click

from ..errors import counted


def run_summary(source, result):
    """One line: points, method, scales, units, undefined, capped, duplicate and left-out counts."""
    from ..reporting.sections import scales_text

    m = result.metadata
    text = (f"{source}: {counted(m['n_points'], 'point')}, {m['descriptor']} {m['strategy']}, {scales_text(m)}, "
            f"{m['weights']} weights, units {m['units']}; {m['n_undefined']:,} undefined")
    if m["n_undefined"]:
        text += " (left out of the signature)"
    if m["n_capped"]:
        text += f", {counted(m['n_capped'], 'neighbourhood')} capped at {m['max_neighbors']}"
    if m["n_duplicates"]:
        text += f", {counted(m['n_duplicates'], 'duplicate point')} (one location each)"
    if m.get("n_excluded"):
        text += f", {counted(m['n_excluded'], 'withheld or noise point')} left out"
    return text


def archive_summary_line(side):
    """One line for an archive input of compare."""
    from ..reporting.sections import scales_text

    m = side.signature.metadata
    scales = scales_text(m) if "resolved_scales" in m and "scale_kind" in m else m.get("scales", "?")
    what = "set of tiles" if "tiling" in m else "archive"
    return (f"{side.name}: {what} of {counted(side.signature.n_points, 'point')}, {m.get('descriptor', '?')} "
            f"{m.get('strategy', '?')}, {scales}, {m.get('weights', 'none')} weights")


def echo_run(source, result):
    click.echo(run_summary(source, result))
