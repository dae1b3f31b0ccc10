"""Errors a user can cause and fix, and the wording of counts and arguments in messages.

The command line turns a :class:`LidarSigError` into one line on stderr and exit status 2;
anything else is a bug and keeps its traceback. A message names the fix in the words of the
face the user speaks through (:func:`arg`): ``overwrite=True`` in Python, ``--overwrite`` on
the command line.
"""
from __future__ import annotations

import contextlib
import contextvars
import os
from collections.abc import Iterator
from pathlib import Path
from typing import Any

#: The face the user speaks through: "python" (arguments) or "cli" (options, set by the
#: command line for the run of a command).
FACE = contextvars.ContextVar("lidar_sig_face", default="python")


class LidarSigError(ValueError):
    """A problem with the user's input, options or output path; the message names the fix.

    The message is one line whatever it names: a line break or another control character in a
    file name is shown escaped (:func:`printable`), so that it cannot split the message into two
    lines (the second would read as another message); ``path`` keeps the name as given."""

    def __init__(self, message: str, *, path: str | os.PathLike[str] | None = None) -> None:
        self.path = None if path is None else str(path)
        super().__init__(printable(f"{self.path}: {message}" if self.path else message))


class LidarSigWarning(UserWarning):
    """Something a user should know about a result that is still written in full (e.g. a COPC
    input written as plain LAZ); the command line prints it as one note line on stderr."""


class Interrupted(KeyboardInterrupt):
    """SIGINT or SIGTERM arrived: raised where the run can stop cleanly (between blocks of work,
    or once an output being written is complete and its temporary file removed)."""

    def __init__(self, signum: int) -> None:
        import signal

        self.signum = int(signum)
        super().__init__(signal.Signals(self.signum).name)


def arg(name: str, value: object = None) -> str:
    """An argument as the user gives it in the face that runs (:data:`FACE`): ``arg("overwrite",
    True)`` is "overwrite=True" in Python and "--overwrite" on the command line, ``arg("memory",
    "2GiB")`` 'memory="2GiB"' and "--memory 2GiB", ``arg("cell")`` "cell" and "--cell"."""
    if FACE.get() == "cli":
        option = "--" + name.replace("_", "-")
        return option if value is None or value is True else f"{option} {value}"
    return name if value is None else f"{name}={value!r}"


@contextlib.contextmanager
def speaking(face: str) -> Iterator[None]:
    """Within the block, messages name arguments as ``face`` ("python" or "cli") takes them."""
    token = FACE.set(face)
    try:
        yield
    finally:
        FACE.reset(token)


def whole_number(value: Any, what: str, *, low: int = 0, high: int | None = None) -> int:
    """``value`` as an int if it is a whole number (not a bool) from ``low`` to ``high``; else a
    LidarSigError naming ``what`` and the value."""
    import numpy as np

    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < low \
            or (high is not None and value > high):
        bounds = f">= {low:,}" if high is None else f"from {low:,} to {high:,}"
        raise LidarSigError(f"{what} must be a whole number {bounds}, got {value!r}")
    return int(value)


def yes_no(value: Any, what: str) -> bool:
    """``value`` as a bool if it is one (numpy's too); else a LidarSigError naming ``what`` and
    the value: ``overwrite="no"`` is a non-empty text, true to Python, and would overwrite."""
    import numpy as np

    if not isinstance(value, (bool, np.bool_)):
        raise LidarSigError(f"{what} must be True or False, got {value!r}")
    return bool(value)


def positive_metres(value: Any, what: str) -> float:
    """``value`` as a float if it is a positive finite number (not a bool); else a
    LidarSigError saying that ``what`` must be a positive number of metres (a whole number too
    large for a float, such as 10**400, included)."""
    import math

    import numpy as np

    number = None
    if not isinstance(value, bool) and isinstance(value, (int, float, np.integer, np.floating)):
        try:
            number = float(value)
        except OverflowError:  # an int beyond the largest float
            number = None
    if number is None or not math.isfinite(number) or number <= 0:
        raise LidarSigError(f"{what} must be a positive number of metres, got {brief(value)}")
    return number


def brief(value: object) -> str:
    """The repr of ``value`` for a message, at most about 50 characters (10**400 has 401 digits)."""
    text = repr(value)
    return text if len(text) <= 40 else f"{text[:20]}...{text[-8:]} ({len(text):,} characters)"


def as_path(value: Any, what: str) -> Path:
    """``value`` (a str or path-like, not empty, whose names the file system can hold: see
    :func:`check_name_lengths`) as a Path; else a LidarSigError saying that ``what`` takes a
    path and what it got (its type, not its repr: an array's is many lines)."""
    if isinstance(value, (str, os.PathLike)) and str(value) != "":
        path = Path(value)
        check_name_lengths(path)
        return path
    got = "an empty path" if isinstance(value, (str, os.PathLike)) else a_kind(value)
    raise LidarSigError(f"{what} takes a file path, got {got}")


#: Longest name of a file or folder, in bytes, where the file system does not say (ext4, XFS,
#: Btrfs, tmpfs and APFS take 255).
NAME_MAX = 255
#: Longest path, in bytes, that the system takes (Linux's PATH_MAX).
PATH_MAX = 4096


def check_name_lengths(path: str | os.PathLike[str], room: int = 0) -> None:
    """Refuse ``path`` when one of its names is longer than its file system takes (255 bytes on
    most: about 85 CJK characters), or ``room`` bytes less for the last one (an output gets a
    temporary file named after it beside it), or when the whole path is longer than the system
    takes: a LidarSigError naming the path and the fix, instead of the system's "File name too
    long" at the first look at it."""
    path = Path(path)
    size = len(os.fsencode(os.path.abspath(path)))
    if size >= PATH_MAX:
        raise LidarSigError(f"the path is {size:,} bytes long, more than the {PATH_MAX - 1:,} the system takes; "
                            "give a shorter path", path=path)
    names = path.parts
    for i, name in enumerate(names):
        last = i == len(names) - 1
        limit = _name_limit(path.parent if last else Path(*names[:i]) if i else Path(".")) - (room if last else 0)
        length = len(os.fsencode(name))
        if length > limit:
            what = "the name" if last else f"the folder name {name[:12]}..."
            why = f"at most {limit} here" + (" (a temporary file named after it is written beside it)" if room else "")
            raise LidarSigError(f"{what} is {length} bytes long, {why}; give a shorter name", path=path)


def _name_limit(folder: Path) -> int:
    """The longest file name (bytes) the file system of ``folder`` (or of its nearest folder
    that exists) takes."""
    for where in (folder, *folder.parents):
        try:
            return int(os.pathconf(where, "PC_NAME_MAX"))
        except (OSError, ValueError, AttributeError):  # no such folder; no pathconf (Windows)
            continue
    return NAME_MAX


def special_file(path: str | os.PathLike[str]) -> str | None:
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


def a_kind(value: object) -> str:
    """What ``value`` is, for a message: "None", "an int", "a list" (its type, not its repr:
    an array's is many lines)."""
    if value is None:
        return "None"
    name = type(value).__name__
    return f"{'an' if name[:1].lower() in 'aeiou' else 'a'} {name}"


def counted(n: int, noun: str, plural: str | None = None) -> str:
    """``n`` and the noun, singular for one: "1 point", "2 points", "12,345 classes" (``plural``
    for nouns that do not take an s); see :func:`amount`."""
    return f"{amount(n)} {noun if n == 1 else plural or noun + 's'}"


def amount(n: int | float) -> str:
    """A whole number for a message: "12,345"; "2.5e+23" from 1e15 on, which no count of points
    or cells reaches (an absurd option, say a cell of 1e12 m, would otherwise print 25 digits);
    "about 1e+400" beyond the largest float."""
    if abs(n) < 1e15:
        return f"{n:,}"
    try:
        return f"{float(n):.3g}"
    except OverflowError:
        return f"about 1e+{len(str(abs(int(n)))) - 1}"


#: Characters that end a line (str.splitlines splits there) or drive a terminal: shown escaped.
_UNPRINTABLE = {c: f"\\x{c:02x}" for c in [*range(32), *range(127, 160)]}
_UNPRINTABLE.update({ord("\n"): "\\n", ord("\r"): "\\r", ord("\t"): "\\t", 0x2028: "\\u2028", 0x2029: "\\u2029"})


def printable(text: object) -> str:
    """``text`` as one line a terminal shows as it is: line breaks, tabs and other control
    characters (a file may be named "a\\nb") written as Python writes them in a string (``\\n``,
    ``\\t``, ``\\x1b``). Messages, notes, printed lines and reprs pass through it."""
    return str(text).translate(_UNPRINTABLE)


def reason(exc: BaseException) -> str:
    """The first line of an exception's message, at most 160 characters (its type when it has
    none): what a library said about a damaged input, for a LidarSigError naming the file."""
    text = str(exc).strip().splitlines()
    return (text[0] if text else type(exc).__name__)[:160]
