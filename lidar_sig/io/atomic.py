"""Outputs appear whole or not at all: write to a temporary file beside, then rename."""
from __future__ import annotations

import contextlib
import os
import tempfile
from pathlib import Path

from ..errors import LidarSigError


def check_output(path, *, overwrite=False):
    """Refuse an output path that exists (unless ``overwrite``) or whose folder is missing."""
    path = Path(path)
    if path.exists() and not overwrite:
        raise LidarSigError("output already exists; pass --overwrite to replace it", path=path)
    if path.is_dir():
        raise LidarSigError("output is a folder; give a file name", path=path)
    parent = path.parent if str(path.parent) else Path(".")
    if not parent.is_dir():
        raise LidarSigError("the output folder does not exist; create it first", path=path)
    return path


@contextlib.contextmanager
def atomic_output(path, *, overwrite=False):
    """Yield a temporary path in the same folder; rename it to ``path`` only on success.

    The temporary name ends with the output's extension, for writers that choose the format
    from it.
    """
    path = check_output(path, overwrite=overwrite)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=f".tmp{path.suffix}", dir=path.parent or ".")
    os.close(fd)
    try:
        yield Path(tmp)
        if path.exists() and not overwrite:  # appeared while we were working
            raise LidarSigError("output already exists; pass --overwrite to replace it", path=path)
        os.replace(tmp, path)
    finally:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(tmp)
