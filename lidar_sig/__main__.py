"""``python -m lidar_sig`` and the ``lidar-sig`` command: the command line, with Ctrl-C and
SIGTERM handled from its first instant (the libraries take a second to load)."""
import signal
import sys


def _terminate(signum, frame):
    from .errors import Interrupted

    raise Interrupted(signum)


def main(argv=None):
    """Start the command line; returns the exit status."""
    try:
        # what the SIGTERM handler raises, loaded whole before the handler can run (a SIGTERM
        # while the command line was importing it raised an ImportError of a partly loaded module)
        from . import errors  # noqa: F401
        signal.signal(signal.SIGTERM, _terminate)
        from .cli import main as cli_main
    except KeyboardInterrupt as exc:  # Ctrl-C or SIGTERM while the libraries load
        signum = getattr(exc, "signum", signal.SIGINT)
        print(f"lidar-sig: interrupted ({signal.Signals(signum).name}) while starting; nothing was written",
              file=sys.stderr)
        return 128 + signum
    try:
        return cli_main(argv)
    finally:
        # The command has ended and said so: a signal from now on ends the process as the
        # system would, instead of raising in interpreter shutdown or an exit handler (a
        # traceback, or "Exception ignored", after the outputs were already complete).
        signal.signal(signal.SIGTERM, signal.SIG_DFL)
        signal.signal(signal.SIGINT, signal.SIG_DFL)


if __name__ == "__main__":
    sys.exit(main())
