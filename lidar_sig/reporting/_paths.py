"""Where a report and its plots may be written: checked before any computing, so that a bad path
costs nothing."""
from __future__ import annotations

import os
from collections.abc import Iterable
from pathlib import Path

from ..base.errors import LidarSigError, arg, as_path

HTML_EXTENSIONS = (".html", ".htm")


def check_report_path(path: str | os.PathLike[str], *, overwrite: bool = True) -> None:
    """Refuse a report path without an .html extension (and, unless ``overwrite``, one that
    exists) or in a folder that is missing or not writable: before any computing."""
    from ..io.atomic import check_output

    if Path(path).suffix.lower() not in HTML_EXTENSIONS:
        raise LidarSigError("the report is written as .html", path=path)
    check_output(path, overwrite=overwrite)
    _check_writable(Path(path).parent, path)


def check_plots_folder(folder: str | os.PathLike[str], names: Iterable[str], *, overwrite: bool = False) -> None:
    """Refuse a plots folder that is a file, whose parent is missing or not writable, or that
    holds a file of ``names`` already (unless ``overwrite``): before any computing."""
    folder = as_path(folder, "the plots folder")
    if folder.exists() and not folder.is_dir():
        raise LidarSigError("is a file, not a folder for the plots; give a folder", path=folder)
    parent = folder if folder.is_dir() else folder.parent
    if not (parent if str(parent) else Path(".")).is_dir():
        raise LidarSigError("the folder above the plots folder does not exist; create it first", path=folder)
    _check_writable(parent, folder)
    if not overwrite:
        taken = [n for n in names if (folder / n).exists()]
        if taken:
            raise LidarSigError(f"already holds {', '.join(taken)}; pass {arg('overwrite', True)} to replace them "
                                "or give another folder", path=folder)


def _check_writable(folder, path):
    folder = folder if str(folder) else Path(".")
    if folder.is_dir() and not os.access(folder, os.W_OK | os.X_OK):
        raise LidarSigError("cannot write in this folder (permission denied); choose another", path=path)
