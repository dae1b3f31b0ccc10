"""``python -m lidar_sig`` and the ``lidar-sig`` command: the command line, with Ctrl-C and
SIGTERM handled from its first instant (before the command line has loaded) to its last.

The last instant: once the command has ended, the process ends at once with its status
(``os._exit``, after flushing the output), without the interpreter's shutdown. That shutdown
takes a noticeable time (docs/performance.md) and runs no signal handler: a signal then ended the process by the signal
itself (status -2 or -15, no message) although its outputs had just replaced the old ones. A
signal after the command has ended is now said (status 130 or 143 and one line: the outputs
are whole); one that comes after that last look dies with the process.
"""
import os
import signal
import sys

from .base import start

SIGNALS = (signal.SIGINT, signal.SIGTERM)


def _terminate(signum, frame):
    from .base.errors import Interrupted

    raise Interrupted(signum)


def main(argv=None):
    """The command line. Without ``argv`` (the ``lidar-sig`` script, ``python -m lidar_sig``) it
    is the program: it reads ``sys.argv`` and ends the process with the exit status. Given
    ``argv`` it runs the command in this process and returns the exit status, the caller's
    signal handlers put back."""
    program = argv is None
    previous = {s: signal.getsignal(s) for s in SIGNALS}
    if previous[signal.SIGINT] is not signal.SIG_IGN:  # a background job keeps ignoring Ctrl-C
        signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        try:
            # what the SIGTERM handler raises, loaded whole before the handler can run (a SIGTERM
            # while the command line was importing it raised an ImportError of a partly loaded
            # module); a Ctrl-C while it loads is said like one while the libraries load
            from .base import errors  # noqa: F401
            signal.signal(signal.SIGTERM, _terminate)
            # Ctrl-C and SIGTERM were held since the package's first line: one that came is
            # delivered now, to the handlers above (lidar_sig/base/start.py)
            start.let_go()
            from .cli import main as cli_main
        except KeyboardInterrupt as exc:  # Ctrl-C or SIGTERM while the command line loads
            signum = getattr(exc, "signum", signal.SIGINT)
            print(f"lidar-sig: interrupted ({signal.Signals(signum).name}) while starting; nothing was written",
                  file=sys.stderr)
            status = 128 + signum
        else:
            status = _run(cli_main, argv, program)
    finally:
        if not program:
            for s, handler in previous.items():
                signal.signal(s, signal.SIG_DFL if handler is None else handler)
    if program:
        _end(status)
    return status


def _run(cli_main, argv, program):
    """The command's exit status; a signal that comes once it has ended (it says itself how it
    ended before) is said in one line with status 128 + the signal."""
    late = []
    status = 0
    try:
        status = cli_main(argv)
        _hold(late)  # inside the try: a signal before holding starts is caught below
    except KeyboardInterrupt as exc:  # after the command: during it, the command line handles it
        late.append(getattr(exc, "signum", signal.SIGINT))
        _hold(late)
    if program:  # from here a signal waits, and goes with the process
        signal.pthread_sigmask(signal.SIG_BLOCK, SIGNALS)
        late += [s for s in SIGNALS if s in signal.sigpending()]
    if late and status == 0:
        print(f"lidar-sig: interrupted ({signal.Signals(late[0]).name}) as the command ended; it had finished "
              "and its outputs are whole", file=sys.stderr)
        status = 128 + late[0]
    return status


def _hold(received):
    """Record SIGINT and SIGTERM in ``received`` instead of raising (an ignored one stays so)."""
    for s in SIGNALS:
        if signal.getsignal(s) is not signal.SIG_IGN:
            signal.signal(s, lambda signum, frame: received.append(signum))


def _end(status):
    """End the process with ``status`` now, its output flushed."""
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (OSError, ValueError):  # a closed pipe (`lidar-sig ... | head -1`)
            status = status or 1
    os._exit(status)


if __name__ == "__main__":
    sys.exit(main())
