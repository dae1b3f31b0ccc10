"""Errors a user can cause and fix, and the wording of counts and arguments in messages.

The command line turns a :class:`LidarSigError` into one line on stderr and exit status 2;
anything else is a bug and keeps its traceback. A message names the fix in the words of the
face the user speaks through (:func:`arg`): ``overwrite=True`` in Python, ``--overwrite`` on
the command line.
"""
import contextlib
import contextvars
import os
from pathlib import Path

#: The face the user speaks through: "python" (arguments) or "cli" (options, set by the
#: command line for the run of a command).
FACE = contextvars.ContextVar("lidar_sig_face", default="python")


class LidarSigError(ValueError):
    """A problem with the user's input, options or output path; the message names the fix."""

    def __init__(self, message, *, path=None):
        self.path = None if path is None else str(path)
        super().__init__(f"{self.path}: {message}" if self.path else message)


class LidarSigWarning(UserWarning):
    """Something a user should know about a result that is still written in full (e.g. a COPC
    input written as plain LAZ); the command line prints it as one note line on stderr."""


class Interrupted(KeyboardInterrupt):
    """SIGINT or SIGTERM arrived: raised where the run can stop cleanly (between blocks of work,
    or once an output being written is complete and its temporary file removed)."""

    def __init__(self, signum):
        import signal

        self.signum = int(signum)
        super().__init__(signal.Signals(self.signum).name)


def arg(name, value=None):
    """An argument as the user gives it in the face that runs (:data:`FACE`): ``arg("overwrite",
    True)`` is "overwrite=True" in Python and "--overwrite" on the command line, ``arg("memory",
    "2GiB")`` 'memory="2GiB"' and "--memory 2GiB", ``arg("cell")`` "cell" and "--cell"."""
    if FACE.get() == "cli":
        option = "--" + name.replace("_", "-")
        return option if value is None or value is True else f"{option} {value}"
    return name if value is None else f"{name}={value!r}"


@contextlib.contextmanager
def speaking(face):
    """Within the block, messages name arguments as ``face`` ("python" or "cli") takes them."""
    token = FACE.set(face)
    try:
        yield
    finally:
        FACE.reset(token)


def whole_number(value, what, *, low=0, high=None):
    """``value`` as an int if it is a whole number (not a bool) from ``low`` to ``high``; else a
    LidarSigError naming ``what`` and the value."""
    import numpy as np

    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < low \
            or (high is not None and value > high):
        bounds = f">= {low:,}" if high is None else f"from {low:,} to {high:,}"
        raise LidarSigError(f"{what} must be a whole number {bounds}, got {value!r}")
    return int(value)


def positive_metres(value, what):
    """``value`` as a float if it is a positive finite number (not a bool); else a
    LidarSigError saying that ``what`` must be a positive number of metres."""
    import math

    import numpy as np

    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)) \
            or not math.isfinite(value) or value <= 0:
        raise LidarSigError(f"{what} must be a positive number of metres, got {value!r}")
    return float(value)


def as_path(value, what):
    """``value`` (a str or path-like, not empty) as a Path; else a LidarSigError saying that
    ``what`` takes a path and what it got (its type, not its repr: an array's is many lines)."""
    if isinstance(value, (str, os.PathLike)) and str(value) != "":
        return Path(value)
    got = "an empty path" if isinstance(value, str) else a_kind(value)
    raise LidarSigError(f"{what} takes a file path, got {got}")


def special_file(path):
    """What ``path`` is when it is neither a regular file nor a folder: "a FIFO", "a socket", "a
    device"; None when it is one of those or does not exist (a link is followed). Reading a FIFO
    or a device waits for a writer, maybe forever: such paths are refused as inputs."""
    import stat

    try:
        mode = os.stat(path).st_mode
    except (OSError, ValueError):
        return None
    if stat.S_ISREG(mode) or stat.S_ISDIR(mode):
        return None
    return "a FIFO" if stat.S_ISFIFO(mode) else "a socket" if stat.S_ISSOCK(mode) else "a device"


def a_kind(value):
    """What ``value`` is, for a message: "None", "an int", "a list" (its type, not its repr:
    an array's is many lines)."""
    if value is None:
        return "None"
    name = type(value).__name__
    return f"{'an' if name[:1].lower() in 'aeiou' else 'a'} {name}"


def counted(n, noun, plural=None):
    """``n`` and the noun, singular for one: "1 point", "2 points", "12,345 classes" (``plural``
    for nouns that do not take an s); see :func:`amount`."""
    return f"{amount(n)} {noun if n == 1 else plural or noun + 's'}"


def amount(n):
    """A whole number for a message: "12,345"; "2.5e+23" from 1e15 on, which no count of points
    or cells reaches (an absurd option, say a cell of 1e12 m, would otherwise print 25 digits)."""
    return f"{n:,}" if abs(n) < 1e15 else f"{float(n):.3g}"


def reason(exc):
    """The first line of an exception's message, at most 160 characters (its type when it has
    none): what a library said about a damaged input, for a LidarSigError naming the file."""
    text = str(exc).strip().splitlines()
    return (text[0] if text else type(exc).__name__)[:160]
