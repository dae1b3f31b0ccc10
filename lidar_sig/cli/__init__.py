"""The ``lidar-sig`` command line: parsing and printing only, the science is in the library.

Every way a run can end says so in one line on stderr: a user error (LidarSigError, or a bad
option) with exit status 2; an interrupt (Ctrl-C, SIGTERM) with 130 or 143, outputs left as they
were; a note from the library (LidarSigWarning) is one line too and does not stop the run.
"""
import signal
import warnings

import click

from ..errors import Interrupted, LidarSigError, LidarSigWarning
from ..progress import say


def _note(message, category, filename, lineno, file=None, line=None, _shown=warnings.showwarning):
    if issubclass(category, LidarSigWarning):
        say(f"lidar-sig: note: {message}")  # above a step line that may be showing
    else:
        _shown(message, category, filename, lineno, file, line)


class _Group(click.Group):
    def invoke(self, ctx):
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("always", LidarSigWarning)
                warnings.showwarning = _note
                return super().invoke(ctx)
        except LidarSigError as exc:
            click.echo(f"lidar-sig: error: {exc}", err=True)
            ctx.exit(2)
        except KeyboardInterrupt as exc:  # Ctrl-C, or SIGTERM as Interrupted
            signum = exc.signum if isinstance(exc, Interrupted) else signal.SIGINT
            name = signal.Signals(signum).name
            click.echo(f"lidar-sig: interrupted ({name}); outputs not written, earlier ones left as they were",
                       err=True)
            ctx.exit(128 + signum)


@click.group(cls=_Group, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(package_name="lidar_sig")
def cli():
    """Semantic signatures of airborne LiDAR point clouds, and their comparison."""


from . import changes, compare, info, plugins, resilience, saliency, signature  # noqa: E402,F401  (registers the commands)


def main(argv=None):
    """Run the command line; returns the exit status (``lidar_sig.__main__.main`` first installs
    the signal handlers)."""
    try:
        status = cli.main(args=argv, prog_name="lidar-sig", standalone_mode=False)
    except click.exceptions.NoArgsIsHelpError as exc:
        click.echo(exc.ctx.get_help())
        return 0
    except click.ClickException as exc:  # bad option or argument: one line, not click's three
        command = f"lidar-sig {exc.ctx.info_name}" if getattr(exc, "ctx", None) and exc.ctx.parent else "lidar-sig"
        message = exc.format_message().rstrip(".")
        click.echo(f"lidar-sig: error: {message}{' ' if message.endswith('?') else '; '}see `{command} --help`",
                   err=True)
        return exc.exit_code
    except click.exceptions.Abort:  # Ctrl-C while click itself was prompting or parsing
        click.echo("lidar-sig: interrupted (SIGINT)", err=True)
        return 130
    return status if isinstance(status, int) else 0

