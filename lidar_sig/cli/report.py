"""Printing of run summaries shared by the commands."""
import click


def run_summary(source, result):
    """One line: points, undefined, capped, scales in file units."""
    m = result.metadata
    unit = "" if m["scale_kind"] == "knn" else " (file units)"
    scales = ", ".join(f"{v:.4g}" for v in m["resolved_scales"])
    text = (f"{source}: {m['n_points']:,} points, {m['descriptor']} {m['strategy']}, "
            f"{'k' if m['scale_kind'] == 'knn' else 'radii'} {scales}{unit}; "
            f"{m['n_undefined']:,} undefined (excluded)")
    if m["n_capped"]:
        text += f", {m['n_capped']:,} neighbourhoods capped at {m['max_neighbors']}"
    return text


def echo_run(source, result):
    click.echo(run_summary(source, result))
