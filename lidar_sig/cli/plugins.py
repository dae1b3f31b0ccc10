"""`lidar-sig plugins`: the registered descriptors and strategies."""
import click

from .group import cli


@cli.command()
def plugins():
    """List registered descriptors and scale strategies (name, package, description)."""
    from ..plugins import available

    for kind, title in (("descriptor", "descriptors"), ("strategy", "strategies")):
        click.echo(f"{title}:")
        for name, (package, summary) in available(kind).items():
            click.echo(f"  {name:<12} {package:<14} {summary}")
