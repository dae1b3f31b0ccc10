"""`lidar-sig plugins`: every registered descriptor, strategy, metric, format and command, with the
package it came from."""
import json

import click

from .options import json_option
from .summaries import say


@click.command()
@json_option
def plugins(as_json):
    """List what is installed: descriptors, scale strategies, metrics, point-cloud formats and
    commands (name, package, description), lidar_sig's own and other packages'."""
    from ..jobs import plugins as list_plugins

    done = list_plugins()
    if as_json:
        click.echo(json.dumps(done.to_dict()))
        return
    for line in done.lines:
        say(line)
