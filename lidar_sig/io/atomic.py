"""Outputs appear whole or not at all: write to a temporary file beside, then rename.

The file gets the mode an ordinary ``open(path, "w")`` would give it: 0666 less the umask for a
new file (0644 under umask 022), the old mode for a file being overwritten.
"""
from __future__ import annotations

import contextlib
import os
import stat
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
        # mkstemp creates 0600, private to us; set the mode only now, after any writer has
        # (re)created the temporary file.
        os.chmod(tmp, _output_mode(path))
        os.replace(tmp, path)
    finally:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(tmp)


def _output_mode(path):
    """Permission bits for ``path``: those of the file it replaces, else 0666 less the umask."""
    try:
        return stat.S_IMODE(os.stat(path).st_mode)
    except FileNotFoundError:
        mask = os.umask(0)  # the only portable way to read the umask is to set it
        os.umask(mask)
        return 0o666 & ~mask
