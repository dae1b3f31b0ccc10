"""`lidar-sig plugins`: the registered descriptors and strategies."""
import json

import click

from .group import cli
from .options import json_option


@cli.command()
@json_option
def plugins(as_json):
    """List registered descriptors and scale strategies (name, package, description)."""
    from ..plugins import available

    found = {title: available(kind) for kind, title in (("descriptor", "descriptors"), ("strategy", "strategies"))}
    if as_json:
        click.echo(json.dumps({title: {name: {"package": package, "summary": summary}
                                       for name, (package, summary) in names.items()}
                               for title, names in found.items()}))
        return
    for title, names in found.items():
        click.echo(f"{title}:")
        for name, (package, summary) in names.items():
            click.echo(f"  {name:<12} {package:<14} {summary}")
