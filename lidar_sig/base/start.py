"""The first instant of the command line. When this package is the program being started
(``lidar-sig``, ``python -m lidar_sig``), Ctrl-C and SIGTERM are held (blocked, so that one
that comes waits) from the first line of ``lidar_sig/__init__.py`` until the command line
handles them (:mod:`lidar_sig.__main__`): one that comes while Python loads the package and
the command line is then said in one line, where it was a KeyboardInterrupt traceback or a
silent end (status -15). A program that only imports lidar_sig is left alone. A Ctrl-C that
came while Python read the package's first file is raised at its first call: that call installs
a handler that records it, so that it too is said in one line (or given back, in a program that
only imports lidar_sig, to the handler it replaced). (Before that, while Python itself starts, a
signal acts as on any program.)
"""
from __future__ import annotations

import os
import sys

# the C module, loaded with the interpreter: ``signal`` would take half a millisecond to load,
# a moment in which a Ctrl-C would still be a traceback
import _signal

#: The signals this module holds for the command line, or None; :func:`let_go` lets them come.
held: set[int] | None = None


#: The names of the ``lidar-sig`` script (on Windows: its launcher and the script it runs).
SCRIPT_NAMES = ("lidar-sig", "lidar-sig.exe", "lidar-sig-script.py")


def is_the_program() -> bool:
    """True when the process is the command line starting: ``lidar-sig``, its script the
    program's main module, or ``python -m lidar_sig`` while Python finds the package
    (``sys.argv[0]`` is then "-m"). Not a worker process of a run in tiles: it is started
    with the command's arguments, and may run its script (as ``__mp_main__``), but its main
    module is multiprocessing's."""
    argv = sys.argv
    if not argv:
        return False
    if argv[0] == "-m":
        options = getattr(sys, "orig_argv", [])
        for i, option in enumerate(options):  # the module named after the first -m
            if option == "-m":
                return options[i + 1:i + 2] == ["lidar_sig"]
            if option.startswith("-m"):
                return option[2:] == "lidar_sig"
        return False
    main = getattr(sys.modules.get("__main__"), "__file__", None) or ""
    return os.path.basename(argv[0]) in SCRIPT_NAMES and os.path.basename(main) in SCRIPT_NAMES


def hold(blocked_before: set[int] | None = None, *, handler: tuple = (None, None),
         received: list[int] | None = None) -> None:
    """Hold SIGINT and SIGTERM (those not held already) when this process is the command line
    starting (:func:`is_the_program`); nothing otherwise. ``blocked_before``: the signals that
    were blocked before the package's first line blocked both (the mask it returned);
    ``handler``: (the SIGINT handler it installed, the one it replaced), and ``received``: what
    that handler recorded meanwhile. The replaced handler is put back; in the program a Ctrl-C
    recorded is delivered with those held (:func:`let_go`), elsewhere to that handler at once."""
    global held
    installed, before = handler
    if before is _signal.SIG_IGN:  # a background job ignores Ctrl-C: one that came meanwhile too
        received = []
    if installed is not None and before is not installed and _signal.getsignal(_signal.SIGINT) is installed:
        _signal.signal(_signal.SIGINT, _signal.default_int_handler if before is None else before)
    if not hasattr(_signal, "pthread_sigmask"):  # nothing can be held (Windows): a Ctrl-C recorded comes now
        for signum in received or ():
            _signal.raise_signal(signum)
        return
    signals = {_signal.SIGINT, _signal.SIGTERM}
    if blocked_before is None:  # not blocked yet
        blocked_before = set(_signal.pthread_sigmask(_signal.SIG_BLOCK, signals))
    ours = signals - set(blocked_before)
    if held is None and is_the_program():
        held = ours
        _early.extend(received or ())
        return
    if ours:  # not the program (or held already): the mask as it was
        _signal.pthread_sigmask(_signal.SIG_UNBLOCK, ours)
    for signum in received or ():
        _signal.raise_signal(signum)  # as if the package had not been there


#: Signals recorded before they were held, delivered by :func:`let_go`.
_early: list[int] = []


def let_go() -> None:
    """Let the signals :func:`hold` held come (one that came meanwhile is delivered now, to the
    handlers the command line has installed)."""
    global held
    if held:
        _signal.pthread_sigmask(_signal.SIG_UNBLOCK, held)
    held = None
    while _early:
        _signal.raise_signal(_early.pop(0))
