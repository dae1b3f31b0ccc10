"""The work folder of a tiled run: made, refused when it would hold something else or one of the
run's inputs and outputs, removed after a complete run; and what a resumed run reads back from
it besides the staged files and the tiles' results (the area-weight cap, which goes with the
tiles' second-neighbour distances kept beside it)."""
from __future__ import annotations

import json
import shutil
from pathlib import Path

from ..errors import LidarSigError

#: File that marks a folder as a work folder of ours (only such a folder is ever removed).
WORK_MARK = "LIDAR_SIG_WORK"
#: File of the set's area-weight cap, for a resumed run.
AREA_CAP_FILE = "area_cap.json"


def prepare_work(work, resume, keep=()):
    """The work folder, made (or emptied, without ``resume``); refuses a folder that holds
    anything but an earlier run's work, or that is or holds one of the paths ``keep`` (inputs and
    outputs: the folder is removed after a complete run)."""
    work = Path(work).resolve()
    for p in keep:
        p = Path(p).resolve()
        if p == work or work in p.parents:
            raise LidarSigError(f"would hold {p}, but the work folder is removed after the run; give "
                                "--work-dir a folder of its own", path=work)
    if work.exists() and not work.is_dir():
        raise LidarSigError("is a file, not a folder; give --work-dir a new or empty folder", path=work)
    if work.exists() and any(work.iterdir()) and not (work / WORK_MARK).is_file():
        raise LidarSigError("is not empty and not a lidar_sig work folder; give a new or empty folder as "
                            "--work-dir", path=work)
    if work.exists() and not resume:
        shutil.rmtree(work)
    work.mkdir(parents=True, exist_ok=True)
    (work / WORK_MARK).write_text("scratch files of a tiled lidar_sig run; safe to delete\n")
    return work


def remove_work(work):
    """Remove a work folder of ours (after a complete run)."""
    if (Path(work) / WORK_MARK).is_file():
        shutil.rmtree(work, ignore_errors=True)


def discard_work(work):
    """Remove a temporary work folder made for one run (all of it: it was made new and holds
    nothing else)."""
    shutil.rmtree(work, ignore_errors=True)


def saved_area_cap(work, key):
    """The area-weight cap an earlier run of the same set and method (``key``, see
    :meth:`lidar_sig.tiling.tasks.Plan.key`) saved in ``work``, or None."""
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
