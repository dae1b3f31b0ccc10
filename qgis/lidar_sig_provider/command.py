"""Running the ``lidar-sig`` command as a child process and reading what it says (docs/scripting.md):
progress lines, notes, the one-line error, the exit status. Plain Python (no QGIS), so that it
is tested without QGIS.

The command runs with ``LIDAR_SIG_PROGRESS=lines``: its stderr then carries one line per stage
and whole percent, ``lidar-sig: progress: <stage>: <N>%``; notes are ``lidar-sig: note: ...``;
a user error ends with ``lidar-sig: error: ...`` and exit status 2; SIGTERM stops it within a
block of work, with nothing half-written, and status 143.
"""
import functools
import json
import os
import queue
import re
import shutil
import signal
import subprocess
import sys
import threading
from dataclasses import dataclass, field

#: The command's name on PATH.
COMMAND = "lidar-sig"
PROGRESS = re.compile(r"^lidar-sig: progress: (?P<stage>.+): (?P<percent>\d{1,3})%$")
NOTE = "lidar-sig: note: "
ERROR = "lidar-sig: error: "
INTERRUPTED = "lidar-sig: interrupted"
#: Seconds between looks at the cancel button, and the longest wait for the command to stop.
POLL = 0.1
STOP_WAIT = 120


class CommandError(Exception):
    """The command failed (``message`` says why, in one line) or could not start."""

    def __init__(self, message, status=None):
        super().__init__(message)
        self.message = message
        self.status = status


class Cancelled(CommandError):
    """The run was cancelled: the command was sent SIGTERM and stopped."""


@dataclass
class Finished:
    """A run that ended with status 0: what it printed on stdout, its notes."""

    stdout: str
    notes: list = field(default_factory=list)


def find_executable(setting=None):
    """The command to run: ``setting`` (a path, from the provider's settings) when given, else
    ``lidar-sig`` on PATH; a CommandError saying how to get it otherwise."""
    if setting:
        if not (os.path.isfile(setting) and os.access(setting, os.X_OK)):
            raise CommandError(f"{setting}: the lidar-sig executable set in Settings > Options > Processing > "
                               "Providers > lidar_sig is not an executable file; fix the path, or clear it to use "
                               "lidar-sig on PATH")
        return setting
    found = shutil.which(COMMAND)
    if not found:
        raise CommandError("lidar-sig was not found on PATH; install it (pip install lidar-sig) or set its path in "
                           "Settings > Options > Processing > Providers > lidar_sig")
    return found


@functools.lru_cache(maxsize=4)
def listing(executable):
    """What the ``lidar-sig`` at ``executable`` offers (``lidar-sig plugins --json``): its
    descriptors, strategies and metrics, each a dict by name; {} when it cannot say (the run of
    a job then reports why). Asked once per executable and QGIS session."""
    try:
        done = subprocess.run([executable, "plugins", "--json"], capture_output=True, text=True, timeout=120,
                              env=child_environment())
        return json.loads(done.stdout) if done.returncode == 0 else {}
    except (OSError, ValueError, subprocess.SubprocessError):
        return {}


def read_line(line):
    """(kind, value) of a stderr line: ``("progress", (stage, percent))``, ``("note", text)``,
    ``("error", text)``, ``("interrupted", line)`` or ``("other", line)``."""
    line = line.rstrip("\r\n")
    found = PROGRESS.match(line)
    if found:
        return "progress", (found["stage"], int(found["percent"]))
    if line.startswith(NOTE):
        return "note", line[len(NOTE):]
    if line.startswith(ERROR):
        return "error", line[len(ERROR):]
    if line.startswith(INTERRUPTED):
        return "interrupted", line
    return "other", line


def child_environment(base=None):
    """The command's environment: ours, with progress as lines; without PYTHONHOME, which a GIS
    sets for its own Python and which would point the command's Python at the wrong library."""
    env = dict(os.environ if base is None else base)
    env.pop("PYTHONHOME", None)
    env["LIDAR_SIG_PROGRESS"] = "lines"
    return env


def run(argv, *, on_progress=None, on_note=None, on_line=None, cancelled=None, env=None):
    """Run ``argv`` (the executable first) to its end and return :class:`Finished`.

    ``on_progress(stage, percent)``, ``on_note(text)`` and ``on_line(text)`` (any other stderr
    line) are called in this thread as the lines come; ``cancelled()`` is asked every
    :data:`POLL` seconds, and when it says True the command is sent SIGTERM and
    :class:`Cancelled` raised once it has stopped. A status other than 0 raises
    :class:`CommandError` with the command's error line (or its last line).
    """
    try:
        proc = subprocess.Popen(argv, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                env=child_environment(env), text=True, encoding="utf-8", errors="replace", bufsize=1)
    except OSError as exc:
        raise CommandError(f"{argv[0]}: could not be started ({exc.strerror or exc}); check the lidar-sig executable "
                           "in Settings > Options > Processing > Providers > lidar_sig") from None
    lines = queue.Queue()
    out = []
    readers = [threading.Thread(target=_pump, args=(proc.stderr, lines.put), daemon=True),
               threading.Thread(target=_pump, args=(proc.stdout, out.append), daemon=True)]
    for reader in readers:
        reader.start()
    notes, errors, last = [], [], []
    stopping = False

    def handle(line):
        kind, value = read_line(line)
        if kind == "progress":
            if on_progress:
                on_progress(*value)
        elif kind == "note":
            notes.append(value)
            if on_note:
                on_note(value)
        else:
            (errors if kind in ("error", "interrupted") else last).append(value)
            if on_line:
                on_line(value)

    while proc.poll() is None or readers[0].is_alive():
        try:
            line = lines.get(timeout=POLL)
        except queue.Empty:
            line = None
        if line is not None:
            handle(line)
        if not stopping and cancelled is not None and proc.poll() is None and cancelled():
            stopping = True
            _stop(proc)
    for reader in readers:
        reader.join(timeout=5)
    while not lines.empty():
        handle(lines.get())
    status = proc.wait()
    if stopping:
        raise Cancelled("cancelled: " + (errors[-1] if errors else f"lidar-sig stopped (status {status})"), status)
    if status != 0:
        why = errors[-1] if errors else (last[-1] if last else f"lidar-sig ended with status {status}")
        raise CommandError(why, status)
    return Finished("".join(out), notes)


def _pump(stream, put):
    for line in iter(stream.readline, ""):
        put(line)
    stream.close()


def _stop(proc):
    """SIGTERM (the command then stops within a block, nothing half-written), then wait; kill
    only if it has not stopped after :data:`STOP_WAIT` seconds."""
    if sys.platform == "win32":
        proc.terminate()
    else:
        proc.send_signal(signal.SIGTERM)
    try:
        proc.wait(timeout=STOP_WAIT)
    except subprocess.TimeoutExpired:
        proc.kill()
