"""The ``lidar-sig`` command group: its commands and how every run ends.

The commands are those registered under the entry-point group ``lidar_sig.commands``: lidar_sig's
own (one module of this package each) and other packages' (docs/extending.md). The group lists
their names from the installed packages' metadata and imports a command's module only when it
runs or when the group's help shows its short help, as click's lazy groups do: the command line
starts without them.

A user error (LidarSigError, or a bad option) is one line on stderr and exit status 2; an
interrupt (Ctrl-C, SIGTERM) one line and 130 or 143, outputs left as they were; a note from the
library (LidarSigWarning) one line that does not stop the run.
"""
import signal
import warnings

import click

from ..base.errors import Interrupted, LidarSigError, LidarSigWarning, printable, speaking
from ..base.extensions import registered_apart
from ..io.atomic import recording_outputs
from ..base.progress import environment_setting, say


def show_note(message, category, filename, lineno, file=None, line=None, _shown=warnings.showwarning):
    """Show a LidarSigWarning as one note line (``warnings.showwarning``'s signature); others as usual."""
    if issubclass(category, LidarSigWarning):
        say(f"lidar-sig: note: {printable(message)}")  # above a step line that may be showing
    else:
        _shown(message, category, filename, lineno, file, line)


class _Group(click.Group):
    """The commands found through entry points, each loaded when first needed. Another package's
    command that cannot be loaded, or that is named like another command, leaves the others and
    the help working: the help lists it not, with one note naming its package, and running it
    is its one error line."""

    _listing = False  # while the help lists the commands
    _noted: frozenset[str] = frozenset()  # the notes said in this run: each once

    def main(self, *args, **kwargs):
        self._noted = frozenset()  # a new run (the command line called again in one process) says them again
        return super().main(*args, **kwargs)

    def _commands(self) -> dict:
        found, clashes = registered_apart("command")
        for clash in clashes:
            self._note(str(clash))
        return found

    def _note(self, text):
        if text not in self._noted:
            self._noted = self._noted | {text}
            click.echo(printable(f"lidar-sig: note: {text}"), err=True)

    def list_commands(self, ctx: click.Context) -> list[str]:
        return sorted(set(self._commands()) | set(self.commands))

    def get_command(self, ctx: click.Context, cmd_name: str) -> click.Command | None:
        extension = self._commands().get(cmd_name)
        if extension is None:
            return self.commands.get(cmd_name)
        try:
            command = extension.load()
            if not isinstance(command, click.Command):
                raise extension.fault(f"is {command!r}, not a click command (decorate its function with "
                                      "@click.command())")
        except LidarSigError as exc:
            if not self._listing:
                raise  # the command asked for: its one error line
            self._note(f"{exc} (left out of this list)")
            return None
        if not extension.built_in:
            ctx.meta["lidar_sig.plugin_command"] = extension  # its failures name its package
        return command

    def format_commands(self, ctx: click.Context, formatter: click.HelpFormatter) -> None:
        self._listing = True
        try:
            super().format_commands(ctx, formatter)
        finally:
            self._listing = False

    def invoke(self, ctx):
        written = []
        try:
            with warnings.catch_warnings(), recording_outputs() as written, speaking("cli"):
                environment_setting()  # a bad LIDAR_SIG_PROGRESS is refused before any work
                warnings.simplefilter("always", LidarSigWarning)
                warnings.showwarning = show_note
                return super().invoke(ctx)
        except LidarSigError as exc:
            click.echo(f"lidar-sig: error: {exc}", err=True)
            ctx.exit(2)
        except (click.exceptions.ClickException, click.exceptions.Exit, click.exceptions.Abort, SystemExit,
                GeneratorExit):
            raise  # click's own endings, and a command's chosen exit status
        except Exception as exc:
            plugin = ctx.meta.get("lidar_sig.plugin_command")
            if plugin is None:
                raise  # lidar_sig's own command: a bug, with its traceback
            click.echo(printable(f"lidar-sig: error: {plugin.fault('failed', exc)}"), err=True)
            ctx.exit(2)
        except KeyboardInterrupt as exc:  # Ctrl-C, or SIGTERM as Interrupted
            signum = exc.signum if isinstance(exc, Interrupted) else signal.SIGINT
            # a signal before recording began leaves the plain list: no work folder yet
            work = getattr(written, "work", [])
            kept = f"; its work is kept in {', '.join(work)} for --resume" if work else ""
            click.echo(printable(f"lidar-sig: interrupted ({signal.Signals(signum).name}); {_outputs_left(written)}"
                                 f"{kept}"), err=True)
            ctx.exit(128 + signum)


def _outputs_left(written):
    """What an interrupted run leaves: the outputs it renamed into place (whole), and that the
    others were not written (their temporary files removed, earlier files as they were)."""
    if not written:
        return "outputs not written, earlier ones left as they were"
    names = ", ".join(map(str, written[-3:]))
    done = names if len(written) <= 3 else f"{len(written):,} outputs (the last {names})"
    return f"written whole before it: {done}; any other output not written, earlier ones left as they were"


@click.group(cls=_Group, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(package_name="lidar_sig")
def cli():
    """Semantic signatures of airborne LiDAR point clouds, and their comparison."""
