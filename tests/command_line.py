"""Run `lidar-sig ARGS` as a user would, two ways; both return a ``subprocess.CompletedProcess``
(``returncode``, ``stdout``, ``stderr`` as text).

- :func:`run`: in this process. A child process spends most of a second starting Python and
  loading the libraries a command computes with; here they are loaded once, so most tests of
  the command line use this. It is run as a child would be (see :func:`run`).
- :func:`run_process`: in a child process, ``python -m lidar_sig ARGS``. For what only a real
  process shows: signals, the exit status of the process, start-up and imports, entry points of
  installed distributions, a run that must end within a time limit; and a few end-to-end runs of
  each command.
"""
from __future__ import annotations

import contextlib
import logging
import os
import subprocess
import sys
import tempfile
import traceback
import warnings

#: Warnings a fresh interpreter does not show (Python's default filters).
HIDDEN_BY_DEFAULT = (DeprecationWarning, PendingDeprecationWarning, ImportWarning, ResourceWarning)


def run(*args, cwd=None):
    """`lidar-sig ARGS` in this process, as in a child process started from a pipeline:

    - stdout and stderr captured at the file descriptors, so that what C libraries print there
      is captured too; stdin empty; the current folder ``cwd`` during the run;
    - a Python warning is shown on stderr as a fresh interpreter shows it (after the rest of
      stderr), and a log record of WARNING or above that no handler of its logger takes, as
      Python's last-resort handler does;
    - an exception escaping the command line is exit status 1 with its traceback on stderr, as
      the interpreter would end (KeyboardInterrupt, from Ctrl-C on the test run, is not caught).
    """
    from lidar_sig.cli import main

    argv = [str(a) for a in args]
    with _captured() as streams, _folder(cwd), warnings.catch_warnings(record=True) as caught, _last_resort():
        # entering catch_warnings also forgets which warnings were shown before in this process
        try:
            status = main(argv)
        except SystemExit as exc:
            status = _exit_status(exc.code)
        except Exception:  # noqa: BLE001 - the interpreter's own ending of an uncaught exception
            traceback.print_exc(file=sys.stderr)
            status = 1
        for w in caught:
            if not issubclass(w.category, HIDDEN_BY_DEFAULT):
                sys.stderr.write(warnings.formatwarning(w.message, w.category, w.filename, w.lineno, w.line))
    return subprocess.CompletedProcess(["lidar-sig", *argv], status, streams.stdout, streams.stderr)


def run_process(*args, cwd=None, timeout=600):
    """`python -m lidar_sig ARGS` in a child process; stdin closed, as in a pipeline."""
    return subprocess.run([sys.executable, "-m", "lidar_sig", *map(str, args)], capture_output=True, text=True,
                          cwd=cwd, timeout=timeout, stdin=subprocess.DEVNULL)


def _exit_status(code):
    if code is None:
        return 0
    if isinstance(code, int):
        return code
    print(code, file=sys.stderr)
    return 1


class _Output:
    stdout = stderr = ""


@contextlib.contextmanager
def _captured():
    """Point file descriptors 1 and 2, sys.stdout and sys.stderr at two files, and sys.stdin at
    an empty one; the texts are in the yielded object's ``stdout`` and ``stderr`` afterwards."""
    result = _Output()
    saved_streams = sys.stdin, sys.stdout, sys.stderr
    for stream in saved_streams[1:]:
        stream.flush()
    saved_fds = os.dup(1), os.dup(2)
    with tempfile.TemporaryFile() as out, tempfile.TemporaryFile() as err, open(os.devnull) as empty:
        try:
            os.dup2(out.fileno(), 1)
            os.dup2(err.fileno(), 2)
            # line-buffered text on the descriptors, with the encodings of a child's standard streams
            sys.stdout = open(1, "w", encoding="utf-8", buffering=1, closefd=False)
            sys.stderr = open(2, "w", encoding="utf-8", errors="backslashreplace", buffering=1, closefd=False)
            sys.stdin = empty
            yield result
        finally:
            for stream in (sys.stdout, sys.stderr):
                stream.flush()
            sys.stdin, sys.stdout, sys.stderr = saved_streams
            os.dup2(saved_fds[0], 1)
            os.dup2(saved_fds[1], 2)
            for fd in saved_fds:
                os.close(fd)
            for file, name in ((out, "stdout"), (err, "stderr")):
                file.seek(0)
                setattr(result, name, file.read().decode("utf-8", errors="replace"))


@contextlib.contextmanager
def _folder(cwd):
    if cwd is None:
        yield
        return
    previous = os.getcwd()
    os.chdir(cwd)
    try:
        yield
    finally:
        os.chdir(previous)


class _LastResortHandler(logging.Handler):
    """Python's last resort for a record no handler takes (WARNING and above, on stderr). Here
    the test run's own handlers sit on the root logger, so only the loggers below it count."""

    def __init__(self):
        super().__init__(logging.WARNING)

    def emit(self, record):
        logger = logging.getLogger(record.name)
        while logger is not None and logger is not logging.root:
            if logger.handlers:
                return
            logger = logger.parent
        sys.stderr.write(self.format(record) + "\n")


@contextlib.contextmanager
def _last_resort():
    handler = _LastResortHandler()
    logging.root.addHandler(handler)
    try:
        yield
    finally:
        logging.root.removeHandler(handler)
