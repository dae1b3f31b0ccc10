"""The ``lidar-sig`` command line: parsing and printing only, the science is in the library.

Every way a run can end says so in one line on stderr: a user error (LidarSigError, or a bad
option) with exit status 2; an interrupt (Ctrl-C, SIGTERM) with 130 or 143, outputs left as they
were; a note from the library (LidarSigWarning) is one line too and does not stop the run
(:mod:`lidar_sig.cli.group`). One module per command, each registered under the entry-point group
``lidar_sig.commands`` (as another package's commands are) and imported when it runs;
:func:`main` runs them.
"""
import signal

import click

from ..base.errors import LidarSigError, printable
from .group import cli


def main(argv=None):
    """Run the command line; returns the exit status (``lidar_sig.__main__.main`` first installs
    the signal handlers)."""
    try:
        status = cli.main(args=argv, prog_name="lidar-sig", standalone_mode=False)
    except click.exceptions.NoArgsIsHelpError as exc:
        try:
            click.echo(exc.ctx.get_help())
        except LidarSigError as error:  # a command that cannot be loaded for its short help
            click.echo(f"lidar-sig: error: {error}", err=True)
            return 2
        return 0
    except click.ClickException as exc:  # bad option or argument: one line, not click's three
        command = f"lidar-sig {exc.ctx.info_name}" if getattr(exc, "ctx", None) and exc.ctx.parent else "lidar-sig"
        message = printable(exc.format_message().rstrip("."))  # a value with a line break stays on one line
        click.echo(f"lidar-sig: error: {message}{' ' if message.endswith('?') else '; '}see `{command} --help`",
                   err=True)
        return exc.exit_code
    except LidarSigError as exc:  # a command that cannot be loaded, met while parsing (its help, its name)
        click.echo(f"lidar-sig: error: {exc}", err=True)
        return 2
    except click.exceptions.Abort as exc:  # Ctrl-C or SIGTERM while click itself was parsing or closing
        signum = getattr(exc.__cause__, "signum", signal.SIGINT)  # SIGTERM comes as errors.Interrupted
        click.echo(f"lidar-sig: interrupted ({signal.Signals(signum).name})", err=True)
        return 128 + signum
    return status if isinstance(status, int) else 0

