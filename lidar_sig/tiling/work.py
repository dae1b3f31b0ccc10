"""The work folder of a tiled run: made, refused when it would hold something else or one of the
run's inputs and outputs, held by one run at a time and let go when its job ends (:func:`work_scope`),
removed after a complete run or when it holds nothing worth resuming; and what a resumed run
reads back from it besides the staged files and the tiles' results (the area-weight cap, which
goes with the tiles' second-neighbour distances kept beside it)."""
from __future__ import annotations

import contextlib
import contextvars
import errno
import json
import os
import shutil
from collections.abc import Iterator
from pathlib import Path

from ..base.errors import LidarSigError, arg, check_name_lengths
from ..io.atomic import hold, keeping_work, release

#: File that marks a folder as a work folder of ours (only such a folder is ever removed).
WORK_MARK = "LIDAR_SIG_WORK"
#: File of the set's area-weight cap, for a resumed run.
AREA_CAP_FILE = "area_cap.json"
#: Sub-folder of the staged parts of a set's files (each with its record, ``.json``).
STAGED = "stage"
#: Sub-folder of a change map's finished work units (:mod:`lidar_sig.change_map._units`).
UNITS = "units"
#: Sub-folder of the finished tiles (each with its result, ``.npz``, written last).
FINISHED = "tiles"
#: Bytes the lock of a work folder adds to its name (``.NAME.lock`` beside it).
LOCK_ROOM = 6


class WorkFolderError(LidarSigError):
    """A task could not write to the work folder (no space left, read-only): a failure of the
    run, not of the tile it was computing; the run stops and names the folder."""


# Work folders this process holds (path -> the descriptor of its lock): one run at a time
# works in a folder; the system lets go of the lock when the process ends, however it ends.
_HELD = {}
# Work folders whose job is under way in this context (:func:`work_scope`): their end is its end
_SCOPES = contextvars.ContextVar("lidar_sig_work_scopes", default=frozenset())


def prepare_work(work, resume, keep=()):
    """The work folder, made (or emptied, without ``resume``); refuses a folder that holds
    anything but an earlier run's work, that is or holds one of the paths ``keep`` (inputs and
    outputs: the folder is removed after a complete run), whose parent does not exist (a run
    never makes folders above its own), or that cannot be written (a read-only or immutable
    place, a path under a file, /proc): each a LidarSigError naming the folder and the fix. The
    folder is held by this run until the end of its :func:`work_scope`."""
    given = Path(work)
    check_name_lengths(given, room=LOCK_ROOM)
    work = given.resolve()
    for p in keep:
        p = Path(p).resolve()
        if p == work or work in p.parents:
            raise LidarSigError(f"would hold {p}, but the work folder is removed after the run; give "
                                f"{arg('work_dir')} a folder of its own", path=given)
    if work.exists() and not work.is_dir():
        raise LidarSigError(f"is a file, not a folder; give {arg('work_dir')} a new or empty folder", path=given)
    if not work.parent.is_dir():
        file = file_in_the_way(work.parent)
        why = (f"{file} is a file, not a folder;" if file else
               "its parent folder does not exist; create it first, or")
        raise LidarSigError(f"cannot be the work folder: {why} give {arg('work_dir')} another folder", path=given)
    if resume and not any(Path(h) in work.parents for h in _HELD) and not resumable(work):
        import warnings

        from ..base.errors import LidarSigWarning

        # a resumed run that finds nothing says so: its folder may be elsewhere (another --work-dir)
        warnings.warn(f"nothing to resume in {given} (no earlier run's work there): computing from the start; give "
                      f"the run's own {arg('work_dir')} to resume it", LidarSigWarning, stacklevel=3)
    if str(work) not in _HELD:  # another run working there would lose its tiles, or read ours
        _HELD[str(work)] = hold(work, "working in", errors=lambda _: _work_errors(given),
                                fix=f"give this run a folder of its own ({arg('work_dir')}), or wait for that run to "
                                "end and run this command again")
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


def file_in_the_way(folder: Path) -> Path | None:
    """The first part of the path ``folder`` that is a file (so that no folder can be made
    there: ``afile/sub``), or None."""
    for part in reversed([folder, *folder.parents]):
        if part.exists() and not part.is_dir():
            return part
    return None


@contextlib.contextmanager
def work_scope(work: str | os.PathLike[str]) -> Iterator[None]:
    """The block of a job that uses the work folder ``work`` (the run in tiles, then the outputs
    written from it). However the block ends, a folder this run held (:func:`prepare_work`) is
    let go at its end: its lock removed, so that a resumed run or another may use it at once.
    The folder itself (a job removes it after a complete run) is kept when it holds what a
    resumed run reuses (:func:`resumable`) and removed otherwise; after a user error
    (LidarSigError), only finished tiles are worth keeping (the run as asked cannot go on: a
    run with the fix starts again from the tiles), and the error then says where they are kept.
    A block inside another for the same folder (a run in tiles inside its job) leaves this to
    the outer one."""
    key = str(Path(work).resolve())
    if key in _SCOPES.get():
        yield
        return
    token = _SCOPES.set(_SCOPES.get() | {key})
    try:
        yield
    except LidarSigError as exc:
        if _settle(work, resumable(work, finished_only=True)):
            kept = LidarSigError(f"{exc}; its finished tiles are kept in {work} for {arg('resume', True)}")
            kept.path = exc.path
            raise kept from None
        raise
    except BaseException:
        _settle(work, resumable(work))
        raise
    else:
        _settle(work, resumable(work))
    finally:
        _SCOPES.reset(token)


def _settle(work, keep):
    """At the end of a job: a work folder this run held is let go, and removed unless
    ``keep``; True when it is kept (and was this run's)."""
    if str(Path(work).resolve()) not in _HELD:  # not this run's: left as it is
        return False
    if keep:
        let_go(work)
        return True
    remove_work(work)
    return False


def resumable(work: str | os.PathLike[str], finished_only: bool = False) -> bool:
    """True when the work folder ``work`` holds what a resumed run reuses: a finished tile or
    (unless ``finished_only``) a staged part of a file."""
    work = Path(work)
    if not (work / WORK_MARK).is_file():
        return False
    wanted = [(FINISHED, ".npz"), (UNITS, ".npz")] + ([] if finished_only else [(STAGED, ".json")])
    for sub, ext in wanted:
        with contextlib.suppress(OSError):
            if any(p.suffix == ext and not p.name.startswith(".") for p in (work / sub).iterdir()):
                return True
    with contextlib.suppress(OSError):  # a change map's folder holds each epoch's run in its own
        return any(sub.is_dir() and resumable(sub, finished_only) for sub in work.iterdir())
    return False


@contextlib.contextmanager
def _work_errors(work):
    """A file-system error on the work folder as a LidarSigError naming it and the fix."""
    try:
        yield
    except OSError as exc:
        why = {errno.EROFS: "it is on a read-only file system", errno.EACCES: "permission denied",
               errno.EPERM: "the folder does not allow writing (immutable?)", errno.ENOTDIR: "a part of it is a file",
               errno.ENOSPC: "no space left on the device", errno.EDQUOT: "the disk quota is exceeded",
               errno.ENAMETOOLONG: "its name is too long for the file system"}.get(exc.errno, exc.strerror or str(exc))
        fix = "free some space or give" if exc.errno in (errno.ENOSPC, errno.EDQUOT) else "give"
        raise LidarSigError(f"cannot be used as the work folder ({why}); {fix} {arg('work_dir')} a folder you can "
                            "write to", path=work) from None


def remove_work(work: str | os.PathLike[str]) -> None:
    """Remove a work folder of ours (after a complete run), and let go of it."""
    if (Path(work) / WORK_MARK).is_file():
        shutil.rmtree(work, ignore_errors=True)
    keeping_work(Path(work).resolve(), kept=False)
    let_go(work)


def let_go(work):
    """Let another run use the work folder ``work``, which this run held (it stays on disk,
    for a resumed run, unless removed)."""
    fd = _HELD.pop(str(Path(work).resolve()), None)
    if fd is not None:
        release(Path(work).resolve(), fd)


def fresh_work(base):
    """A new, empty work folder of one run inside ``base`` (the execution's ``work_dir``, a
    folder that must exist) or, with None, the temporary folder (``TMPDIR``): two runs of one
    process or of two never share one. :func:`discard_work` removes it."""
    import tempfile

    if base is not None and not Path(base).is_dir():
        file = file_in_the_way(Path(base))
        why = "is a file" if file == Path(base) else f"{file} is a file" if file else "does not exist"
        raise LidarSigError(f"{why}: {arg('work_dir')} must be a folder that exists (each run in tiles makes its "
                            "own folder in it)", path=base)
    with _work_errors(Path(base) if base is not None else Path(tempfile.gettempdir())):
        return Path(tempfile.mkdtemp(prefix="lidar-sig-work-", dir=base))


def discard_work(work):
    """Remove a temporary work folder made for one run (all of it: it was made new and holds
    nothing else)."""
    shutil.rmtree(work, ignore_errors=True)
    keeping_work(Path(work).resolve(), kept=False)
    let_go(work)


def saved_area_cap(work, key):
    """(cap, whether the tiles' second-neighbour distances were kept) of the area-weight cap an
    earlier run of the same set, method and cap rule (``key``, see
    :func:`lidar_sig.tiling.run_set.cap_key`) saved in ``work``, or None."""
    saved = read_record(Path(work) / AREA_CAP_FILE, work)
    if isinstance(saved, dict) and saved.get("key") == key and isinstance(saved.get("cap"), (int, float)):
        return float(saved["cap"]), bool(saved.get("second_known", True))
    return None


def save_area_cap(work, key, cap, second_known):
    """Keep the set's area-weight cap in ``work`` for a resumed run, and whether its pass kept
    every core point's second-neighbour distance (``second_known``)."""
    (Path(work) / AREA_CAP_FILE).write_text(json.dumps({"key": key, "cap": cap, "second_known": second_known}))


def forget_area_cap(work):
    """Remove a kept area-weight cap: the tiles' distances it goes with are being replaced (a
    resumed run must not take the cap of one pass with the distances of another)."""
    (Path(work) / AREA_CAP_FILE).unlink(missing_ok=True)


def save_whole(path, array=None, **arrays):
    """``array`` as the .npy file ``path``, or ``arrays`` as the .npz file ``path``, whole or not
    at all (written beside it under a name of this process, then renamed): what a resumed run
    finds in a work folder is complete."""
    import numpy as np

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.stem}.{os.getpid()}.tmp{path.suffix}")
    if array is not None:
        np.save(tmp, array)
    else:
        np.savez(tmp, **arrays)
    os.replace(tmp, path)


#: File of a work folder that lists what a resumed run found damaged and recomputed.
DAMAGED = "recomputed.txt"


def load_done(path, key, work, extra=()):
    """The arrays of the finished result ``path`` when it was written from ``key``, else None:
    absent, another run's (removed), or damaged (removed and noted in ``work``, :func:`damaged`,
    so that a resumed run recomputes it and says so, where it would otherwise fail the same way
    at every attempt). ``extra``: files written with it (.npy) whose headers must read too; a
    result of another run (another method, or an earlier version that wrote other files) is
    not taken for damaged because its files differ."""
    import numpy as np

    if not path.is_file():
        return None
    try:
        with np.load(path) as done:
            arrays = {k: done[k] for k in done.files}
        if str(arrays["key"]) == key:
            for other in extra:
                np.load(other, mmap_mode="r")  # the header only: a damaged or missing file fails here
            return arrays
    except Exception:  # numpy, zipfile and pickle raise many kinds on a damaged file
        with contextlib.suppress(OSError):
            with open(Path(work) / DAMAGED, "a") as fh:  # appends of a short line are whole
                fh.write(f"{path}\n")
    with contextlib.suppress(OSError):
        path.unlink()
    return None


def damaged(work):
    """The damaged files a run found in the work folder ``work`` (and its sub-folders, a change
    map's epochs) and recomputed; the record is then cleared."""
    found = []
    for record in [Path(work) / DAMAGED, *Path(work).glob(f"*/{DAMAGED}")]:
        with contextlib.suppress(OSError):
            found += [line for line in record.read_text().splitlines() if line]
            record.unlink()
    return found


def read_record(path, work):
    """The JSON record ``path`` of a work folder, or None when absent or damaged (then noted in
    ``work``, as :func:`load_done` notes a damaged result, and removed)."""
    try:
        return json.loads(Path(path).read_text())
    except FileNotFoundError:
        return None
    except (OSError, ValueError):
        with contextlib.suppress(OSError):
            with open(Path(work) / DAMAGED, "a") as fh:
                fh.write(f"{path}\n")
            Path(path).unlink()
        return None
