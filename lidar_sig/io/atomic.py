"""Outputs appear whole or not at all: write to a temporary file beside, then rename.

- The temporary file is hidden and named after its output, the host and the process:
  ``.tile.laz.<host>.<pid>.<random>.tmp.laz``. A process killed outright (SIGKILL) leaves one
  behind; the next run that writes the same output removes it (when its process is gone).
- SIGINT and SIGTERM are held while an output is written and acted on once the writer is done:
  the temporary file is then removed, the output left as it was, and :class:`Interrupted`
  raised. (Signals raised inside a C library's callbacks would otherwise be lost or leave
  half a file.) A writer that works in chunks calls :func:`stop_if_interrupted` between them,
  so that a long streamed write still ends soon after Ctrl-C or SIGTERM.
- Errors of the file system (no space left, read-only or immutable folder, permission) become a
  :class:`LidarSigError` naming the output and the fix.
- Several outputs of one command can be committed together (:func:`output_group`): all
  renamed at the end, none if anything failed. :func:`recording_outputs` lists those renamed
  into place, for a run interrupted after some of them.
- The file gets the mode an ordinary ``open(path, "w")`` would give it: 0666 less the umask for
  a new file (0644 under umask 022), the old mode for a file being overwritten.
- An output that a run reads, then writes again (a catalogue grown) is held by one run at a time
  (:func:`exclusive_output`): a second run is refused, naming the first.
"""
from __future__ import annotations

import contextlib
import contextvars
import errno
import os
import secrets
import signal
import socket
import stat
import threading
import time
from collections.abc import Iterable
from pathlib import Path

from ..base.errors import Interrupted, LidarSigError, arg, check_name_lengths, yes_no

_HOST = socket.gethostname().replace(".", "-")[:32] or "host"
# Outputs written inside an output_group, waiting to be renamed: [(tmp, path, overwrite)]
_PENDING = contextvars.ContextVar("lidar_sig_pending_outputs", default=None)
# Signals received while held by the innermost deferred_signals block (None outside one)
_RECEIVED = contextvars.ContextVar("lidar_sig_received_signals", default=None)
# Outputs renamed into place inside the innermost recording_outputs block (None outside one)
_WRITTEN = contextvars.ContextVar("lidar_sig_written_outputs", default=None)
# Work folders of runs in tiles kept on disk inside the innermost recording_outputs block
_WORK = contextvars.ContextVar("lidar_sig_work_folders", default=None)
_REASONS = {
    errno.ENOSPC: "no space left on the device; free some space or write elsewhere",
    errno.EDQUOT: "the disk quota is exceeded; free some space or write elsewhere",
    errno.EFBIG: "the file is too large for this file system or its limits; write elsewhere",
    errno.EROFS: "the output folder is on a read-only file system; write elsewhere",
    errno.EACCES: "permission denied in the output folder; write elsewhere or change its permissions",
    errno.EPERM: "the output folder does not allow writing (read-only or immutable); write elsewhere",
    errno.ENAMETOOLONG: "the name is too long for the file system; give a shorter name",
}


def check_output(path: str | os.PathLike[str], *, overwrite: bool = False) -> Path:
    """Refuse an output path that exists (unless ``overwrite``), is a folder, whose folder is
    missing or not writable, or whose name leaves no room for the temporary file named after it
    (:func:`temp_name`); return it as a Path."""
    overwrite = yes_no(overwrite, "overwrite")  # "no" is true to Python: it would overwrite
    path = Path(path)
    check_name_lengths(path, room=TEMP_ROOM + len(path.suffix.encode()))
    if path.is_dir():
        raise LidarSigError("output is a folder; give a file name", path=path)
    if os.path.lexists(path) and not overwrite:  # a link to a missing file exists too: it would be replaced
        raise LidarSigError("output already exists" + ("" if path.exists() else " (a link to a missing file)")
                            + f"; pass {arg('overwrite', True)} to replace it", path=path)
    parent = path.parent if str(path.parent) else Path(".")
    if not parent.is_dir():
        raise LidarSigError("the output folder does not exist; create it first", path=path)
    if not os.access(parent, os.W_OK | os.X_OK):
        raise LidarSigError("the output folder is not writable; write elsewhere or change its permissions",
                            path=path)
    return path


def check_outputs(paths: Iterable[str | os.PathLike[str]], *, overwrite: bool = False) -> list[Path]:
    """:func:`check_output` for every path of a command, and refuse one given twice."""
    seen = {}
    for path in paths:
        path = check_output(path, overwrite=overwrite)
        key = os.path.realpath(path)
        if key in seen:
            raise LidarSigError(f"is given twice (also as {seen[key]}); give each output its own name", path=path)
        seen[key] = path
    return list(seen.values())


#: Bytes a temporary file's name adds to its output's, besides the extension (see :func:`temp_name`):
#: the dots, the host (up to 32), the process (up to 7 digits), 8 random characters and ".tmp".
TEMP_ROOM = 55


def temp_name(path):
    """Prefix and suffix of the temporary files of ``path`` (see the module docstring)."""
    path = Path(path)
    return f".{path.name}.{_HOST}.{os.getpid()}.", f".tmp{path.suffix}"


def remove_stale_temps(path):
    """Remove temporary files of ``path`` left by processes of this host that are gone."""
    path = Path(path)
    folder = path.parent if str(path.parent) else Path(".")
    head = f".{path.name}.{_HOST}."
    with contextlib.suppress(OSError):
        for entry in os.scandir(folder):
            name = entry.name
            if not (name.startswith(head) and name.endswith(f".tmp{path.suffix}")):
                continue
            pid = name[len(head):].split(".", 1)[0]
            if pid.isdigit() and not _alive(int(pid)):
                with contextlib.suppress(OSError):
                    os.unlink(entry.path)


def _alive(pid):
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


@contextlib.contextmanager
def atomic_output(path, *, overwrite=False):
    """Yield a temporary path in the same folder; rename it to ``path`` only on success.

    The temporary name ends with the output's extension, for writers that choose the format
    from it. Inside an :func:`output_group` the rename waits for the group's end.
    """
    path = check_output(path, overwrite=overwrite)
    remove_stale_temps(path)
    prefix, suffix = temp_name(path)
    tmp = path.parent / f"{prefix}{secrets.token_hex(4)}{suffix}"
    pending = _PENDING.get()
    committed = False
    try:
        with os_errors(path), deferred_signals():
            tmp.touch(mode=0o600, exist_ok=False)
            yield tmp
            if not tmp.exists():
                raise LidarSigError("the writer produced no file; this is a bug, please report it", path=path)
        if pending is not None:
            pending.append((tmp, path, overwrite))
            committed = True
        else:
            _commit([(tmp, path, overwrite)])
            committed = True
    finally:
        if not committed:
            with contextlib.suppress(OSError):
                os.unlink(tmp)


@contextlib.contextmanager
def exclusive_output(path, doing):
    """Hold ``path`` for this run while the block runs: a run that reads an output and then
    replaces it (a catalogue grown) would otherwise lose what a run doing the same at the same
    time added. The lock is the file ``.NAME.lock`` beside ``path``, locked (``flock``, released
    by the system when a process ends, even killed) and removed at the end; a second run is
    refused, naming the process that holds it (``doing``: what it does, for the message)."""
    fd = hold(path, doing)
    try:
        yield Path(path)
    finally:
        release(path, fd)


def hold(path, doing, errors=None, fix="wait for that run to end, then run this command again"):
    """Lock ``path`` for this run (:func:`exclusive_output`) until :func:`release`: the file
    descriptor of its lock ``.NAME.lock`` beside it; a run holding it already is named in a
    LidarSigError (``doing``: what that run does with it). ``errors``: the context that turns
    a file-system error into a LidarSigError (default :func:`os_errors`, for an output); a lock
    that cannot be made whole (a full disk) is removed, and one that is not a file of ours (a
    folder, a link, which is never followed) is refused, naming it."""
    import fcntl

    path = Path(path)
    lock = lock_path(path)
    while True:
        _check_lock(lock)
        with (errors or os_errors)(path):
            fd = os.open(lock, os.O_RDWR | os.O_CREAT | os.O_NOFOLLOW | os.O_CLOEXEC, 0o644)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            holder = os.read(fd, 200).decode(errors="replace").strip() or "a process not yet named"
            os.close(fd)
            raise LidarSigError(f"another lidar-sig run is {doing} it ({holder}); {fix}", path=path) from None
        except OSError as exc:  # a file system without locks
            os.close(fd)
            raise LidarSigError(f"cannot be locked for this run ({exc.strerror or exc}); write it on a local "
                                "file system", path=path) from None
        # the run that held it may have removed the file between our open and our lock: lock anew
        with contextlib.suppress(OSError):
            if os.path.samestat(os.fstat(fd), os.lstat(lock)):
                break
        os.close(fd)
    try:
        with (errors or os_errors)(path):  # who holds it, for the message of a run refused meanwhile
            os.ftruncate(fd, 0)
            os.write(fd, f"process {os.getpid()} on {socket.gethostname()}, since {time.strftime('%H:%M:%S')}".encode())
    except BaseException:  # a full disk: no lock left behind, not even empty
        release(path, fd)
        raise
    return fd


def lock_path(path: str | os.PathLike[str]) -> Path:
    """The lock file of ``path`` (:func:`hold`): ``.NAME.lock`` beside it."""
    path = Path(path)
    return path.parent / f".{path.name}.lock"


def _check_lock(lock):
    """Refuse a lock path that is not a regular file (a folder, a link, a FIFO put there): it
    is not ours to lock, follow or remove."""
    try:
        mode = os.lstat(lock).st_mode
    except OSError:
        return
    if not stat.S_ISREG(mode):
        kind = ("a folder" if stat.S_ISDIR(mode) else "a link" if stat.S_ISLNK(mode)
                else "not a regular file")
        raise LidarSigError(f"is {kind} where lidar-sig keeps the lock of {lock.name[1:-5]}; remove it, then run "
                            "this command again", path=lock)


def release(path, fd):
    """Let go of ``path``, held by :func:`hold` as ``fd`` (its lock file removed: while it is
    held, no other run removes or replaces it)."""
    with contextlib.suppress(OSError):
        os.unlink(lock_path(path))
    with contextlib.suppress(OSError):
        os.close(fd)


@contextlib.contextmanager
def output_group():
    """Commit every output written inside the block together: each is written to its temporary
    file, and all are renamed at the end, or none if anything failed or was interrupted. Inside
    another group, the block's outputs join that group."""
    if _PENDING.get() is not None:
        yield
        return
    pending = []
    token = _PENDING.set(pending)
    try:
        yield
        _commit(pending)
    finally:
        _PENDING.reset(token)
        for tmp, _, _ in pending:
            with contextlib.suppress(OSError):
                os.unlink(tmp)


def _commit(items):
    """Rename temporary files onto their outputs, with the right mode, signals held."""
    for _, path, overwrite in items:
        if os.path.lexists(path) and not overwrite:  # appeared while we were working
            raise LidarSigError(f"output already exists; pass {arg('overwrite', True)} to replace it", path=path)
    written = _WRITTEN.get()
    with deferred_signals():
        for tmp, path, _ in items:
            with os_errors(path):
                os.chmod(tmp, _output_mode(path))
                os.replace(tmp, path)
            if written is not None:
                written.append(path)


@contextlib.contextmanager
def recording_outputs():
    """Yield a list that gets each output renamed into place inside the block, in order: what
    a run interrupted after some outputs can say it wrote (whole); and, as its attribute
    ``work``, the work folders of runs in tiles on disk at that moment (:func:`keeping_work`),
    which an interrupted run keeps for a resumed one."""
    written = _Written()
    token = _WRITTEN.set(written)
    work_token = _WORK.set(written.work)
    try:
        yield written
    finally:
        _WRITTEN.reset(token)
        _WORK.reset(work_token)


class _Written(list):
    def __init__(self):
        super().__init__()
        self.work = []


def keeping_work(folder, kept=True):
    """Note that the work folder ``folder`` of a run in tiles is on disk (``kept``) or removed,
    for the message of a run interrupted meanwhile (:func:`recording_outputs`)."""
    work = _WORK.get()
    if work is None:
        return
    folder = str(folder)
    inside = [w for w in work if Path(w) in Path(folder).parents]
    if kept and folder not in work and not inside:  # a run's folder inside its job's is said as the job's
        work[:] = [w for w in work if Path(folder) not in Path(w).parents] + [folder]
    elif not kept and folder in work:
        work.remove(folder)


@contextlib.contextmanager
def os_errors(path):
    """Turn a file-system error while writing ``path`` into a LidarSigError that names the fix."""
    try:
        yield
    except OSError as exc:
        reason = _REASONS.get(exc.errno) or f"{exc.strerror or exc}; check the output folder"
        raise LidarSigError(f"could not be written: {reason}", path=path) from None


@contextlib.contextmanager
def deferred_signals():
    """Hold SIGINT and SIGTERM while the block runs; then raise :class:`Interrupted` if one came.

    Only in the main thread (the only one that receives Python signal handlers); elsewhere the
    block runs as is.
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    received = []
    previous = {s: signal.signal(s, lambda signum, frame: received.append(signum))
                for s in (signal.SIGINT, signal.SIGTERM)}
    token = _RECEIVED.set(received)
    try:
        yield
    finally:
        _RECEIVED.reset(token)
        for s, handler in previous.items():
            signal.signal(s, handler)
    if received:
        raise Interrupted(received[0])


def stop_if_interrupted():
    """Raise :class:`Interrupted` if a signal came while held (a point between two chunks of a
    write where stopping leaves nothing behind: the temporary file is removed)."""
    received = _RECEIVED.get()
    if received:
        raise Interrupted(received[0])


def _output_mode(path):
    """Permission bits for ``path``: those of the file it replaces, else 0666 less the umask."""
    try:
        return stat.S_IMODE(os.stat(path).st_mode)
    except FileNotFoundError:
        mask = os.umask(0)  # the only portable way to read the umask is to set it
        os.umask(mask)
        return 0o666 & ~mask
