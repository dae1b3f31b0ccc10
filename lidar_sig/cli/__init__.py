"""The ``lidar-sig`` command line: parsing and printing only, the science is in the library.

A user error (LidarSigError) ends with one line on stderr and exit status 2; a note from the
library (LidarSigWarning) is one line on stderr.
"""
import warnings

import click

from ..errors import LidarSigError, LidarSigWarning


class _Group(click.Group):
    def invoke(self, ctx):
        try:
            with warnings.catch_warnings():
                shown = warnings.showwarning

                def note(message, category, *args, **kwargs):
                    if issubclass(category, LidarSigWarning):
                        click.echo(f"lidar-sig: note: {message}", err=True)
                    else:
                        shown(message, category, *args, **kwargs)

                warnings.simplefilter("always", LidarSigWarning)
                warnings.showwarning = note
                return super().invoke(ctx)
        except LidarSigError as exc:
            click.echo(f"lidar-sig: error: {exc}", err=True)
            ctx.exit(2)


@click.group(cls=_Group, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(package_name="lidar_sig")
def cli():
    """Semantic signatures of airborne LiDAR point clouds, and their comparison."""


from . import compare, info, plugins, resilience, saliency, signature  # noqa: E402,F401  (registers the commands)


def main(argv=None):
    """Console-script entry point."""
    cli.main(args=argv, prog_name="lidar-sig")
