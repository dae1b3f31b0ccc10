"""`lidar-sig plugins`: the registered descriptors and strategies, and the metrics."""
import json

import click

from .group import cli
from .options import json_option


@cli.command()
@json_option
def plugins(as_json):
    """List registered descriptors and scale strategies (name, package, description), and the metrics."""
    from ..metrics import METRICS
    from ..plugins import available

    found = {title: available(kind) for kind, title in (("descriptor", "descriptors"), ("strategy", "strategies"))}
    if as_json:
        listing = {title: {name: {"package": package, "summary": summary} for name, (package, summary) in names.items()}
                   for title, names in found.items()}
        listing["metrics"] = {m.key: {"name": m.name, "summary": m.short, "needs_labels": m.needs_labels}
                              for m in METRICS}
        click.echo(json.dumps(listing))
        return
    for title, names in found.items():
        click.echo(f"{title}:")
        for name, (package, summary) in names.items():
            click.echo(f"  {name:<12} {package:<14} {summary}")
    click.echo("metrics:")
    for m in METRICS:
        click.echo(f"  {m.key:<14} {m.name:<12} {m.short}")
