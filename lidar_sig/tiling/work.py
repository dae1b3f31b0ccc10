"""The work folder of a tiled run: made, refused when it would hold something else or one of the
run's inputs and outputs, removed after a complete run; and what a resumed run reads back from
it besides the staged files and the tiles' results (the area-weight cap, which goes with the
tiles' second-neighbour distances kept beside it)."""
from __future__ import annotations

import contextlib
import errno
import json
import shutil
from pathlib import Path

from ..base.errors import LidarSigError, arg
from ..io.atomic import hold, keeping_work, release

#: File that marks a folder as a work folder of ours (only such a folder is ever removed).
WORK_MARK = "LIDAR_SIG_WORK"
#: File of the set's area-weight cap, for a resumed run.
AREA_CAP_FILE = "area_cap.json"
# Work folders this process holds (path -> the descriptor of its lock): one run at a time
# works in a folder; the system lets go of the lock when the process ends, however it ends.
_HELD = {}


def prepare_work(work, resume, keep=()):
    """The work folder, made (or emptied, without ``resume``); refuses a folder that holds
    anything but an earlier run's work, that is or holds one of the paths ``keep`` (inputs and
    outputs: the folder is removed after a complete run), whose parent does not exist (a run
    never makes folders above its own), or that cannot be written (a read-only or immutable
    place, a path under a file, /proc): each a LidarSigError naming the folder and the fix."""
    given = Path(work)
    work = given.resolve()
    for p in keep:
        p = Path(p).resolve()
        if p == work or work in p.parents:
            raise LidarSigError(f"would hold {p}, but the work folder is removed after the run; give "
                                f"{arg('work_dir')} a folder of its own", path=given)
    if work.exists() and not work.is_dir():
        raise LidarSigError(f"is a file, not a folder; give {arg('work_dir')} a new or empty folder", path=given)
    if not work.parent.is_dir():
        raise LidarSigError(f"cannot be the work folder: its parent folder does not exist; create it first, or "
                            f"give {arg('work_dir')} another folder", path=given)
    if str(work) not in _HELD:  # another run working there would lose its tiles, or read ours
        _HELD[str(work)] = hold(work, "working in", errors=lambda _: _work_errors(given))
    try:
        with _work_errors(given):
            if work.exists() and any(work.iterdir()) and not (work / WORK_MARK).is_file():
                raise LidarSigError(f"is not empty and not a lidar_sig work folder; give {arg('work_dir')} a new "
                                    "or empty folder", path=given)
            if work.exists() and not resume:
                shutil.rmtree(work)
            made = not work.exists()
            try:
                work.mkdir(exist_ok=True)
                (work / WORK_MARK).write_text("scratch files of a tiled lidar_sig run; safe to delete\n")
            except OSError:
                if made:
                    with contextlib.suppress(OSError):
                        shutil.rmtree(work)
                raise
    except BaseException:
        let_go(work)
        raise
    keeping_work(work)
    return work


@contextlib.contextmanager
def _work_errors(work):
    """A file-system error on the work folder as a LidarSigError naming it and the fix."""
    try:
        yield
    except OSError as exc:
        why = {errno.EROFS: "it is on a read-only file system", errno.EACCES: "permission denied",
               errno.EPERM: "the folder does not allow writing (immutable?)", errno.ENOTDIR: "a part of it is a file",
               errno.ENOSPC: "no space left on the device"}.get(exc.errno, exc.strerror or str(exc))
        raise LidarSigError(f"cannot be used as the work folder ({why}); give {arg('work_dir')} a folder you can "
                            "write to", path=work) from None


def remove_work(work):
    """Remove a work folder of ours (after a complete run), and let go of it."""
    if (Path(work) / WORK_MARK).is_file():
        shutil.rmtree(work, ignore_errors=True)
    let_go(work)


def let_go(work):
    """Let another run use the work folder ``work``, which this run held (it stays on disk,
    for a resumed run, unless removed)."""
    work = Path(work).resolve()
    keeping_work(work, kept=False)
    fd = _HELD.pop(str(work), None)
    if fd is not None:
        release(work, fd)


def fresh_work(base):
    """A new, empty work folder of one run inside ``base`` (the execution's ``work_dir``, a
    folder that must exist) or, with None, the temporary folder (``TMPDIR``): two runs of one
    process or of two never share one. :func:`discard_work` removes it."""
    import tempfile

    if base is not None and not Path(base).is_dir():
        raise LidarSigError(f"{arg('work_dir')} must be a folder that exists (each run in tiles makes its own "
                            "folder in it)", path=base)
    with _work_errors(Path(base) if base is not None else Path(tempfile.gettempdir())):
        return Path(tempfile.mkdtemp(prefix="lidar-sig-work-", dir=base))


def discard_work(work):
    """Remove a temporary work folder made for one run (all of it: it was made new and holds
    nothing else)."""
    shutil.rmtree(work, ignore_errors=True)
    let_go(work)


def saved_area_cap(work, key):
    """The area-weight cap an earlier run of the same set and method (``key``, see
    :meth:`lidar_sig.tiling._tasks.Plan.key`) saved in ``work``, or None."""
    path = Path(work) / AREA_CAP_FILE
    if path.is_file():
        saved = json.loads(path.read_text())
        if saved.get("key") == key:
            return float(saved["cap"])
    return None


def save_area_cap(work, key, cap):
    """Keep the set's area-weight cap in ``work`` for a resumed run."""
    (Path(work) / AREA_CAP_FILE).write_text(json.dumps({"key": key, "cap": cap}))


def forget_area_cap(work):
    """Remove a kept area-weight cap: the tiles' distances it goes with are being replaced (a
    resumed run must not take the cap of one pass with the distances of another)."""
    (Path(work) / AREA_CAP_FILE).unlink(missing_ok=True)
