"""Shared tools of the robustness corpus: make hostile inputs and file systems, and check that a
failure is clean (the command line is run by tests/command_line.py)."""
from __future__ import annotations

import contextlib
import hashlib
import os
import subprocess
import uuid
from pathlib import Path

import laspy
import numpy as np
import pytest


def assert_one_line_error(proc, *names, status=2):
    """Exit ``status``, exactly one line on stderr naming each of ``names``, no traceback."""
    assert proc.returncode == status, (proc.returncode, proc.stderr)
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1, proc.stderr
    assert "Traceback" not in proc.stderr
    for name in names:
        assert str(name) in lines[0], (name, lines[0])


def leftovers(folder):
    """Temporary files lidar_sig may have left in ``folder``."""
    return [p.name for p in Path(folder).iterdir() if p.name.startswith(".") and ".tmp" in p.name]


def digests(*paths):
    return {str(p): hashlib.sha256(Path(p).read_bytes()).hexdigest() for p in paths}


def write_las(path, xyz, labels=None, *, scale=0.01, version="1.4"):
    """A LAS file of the points (point format 6 for 1.4, 1 for 1.2)."""
    header = laspy.LasHeader(point_format=6 if version == "1.4" else 1, version=version)
    xyz = np.asarray(xyz, dtype=np.float64)
    header.offsets = np.floor(xyz.min(axis=0))
    header.scales = [scale] * 3
    las = laspy.LasData(header)
    las.x, las.y, las.z = xyz[:, 0], xyz[:, 1], xyz[:, 2]
    if labels is not None:
        las.classification = np.asarray(labels, dtype=np.uint8)
    las.write(path)
    return Path(path)


@contextlib.contextmanager
def mounted_tmpfs(folder, size="64k", read_only=False):
    """A small tmpfs at ``folder`` (a full disk in a few writes), optionally read-only; skips the
    test, saying why, where mounting is not allowed (it needs root and mount rights)."""
    folder = Path(folder) / f"fs-{uuid.uuid4().hex[:8]}"
    folder.mkdir()
    options = f"size={size}" + (",ro" if read_only else "")
    made = subprocess.run(["mount", "-t", "tmpfs", "-o", options, "tmpfs", str(folder)], capture_output=True, text=True)
    if made.returncode != 0:
        pytest.skip(f"cannot mount a small file system here ({made.stderr.strip() or 'mount failed'}); "
                    "this case needs root and mount rights")
    try:
        yield folder
    finally:
        subprocess.run(["umount", "-l", str(folder)], capture_output=True)


def fill(folder, leave=0):
    """Fill the file system of ``folder``, leaving about ``leave`` bytes."""
    stat = os.statvfs(folder)
    free = stat.f_bavail * stat.f_frsize
    if free > leave:
        with open(Path(folder) / "filler", "wb") as fh:
            with contextlib.suppress(OSError):
                fh.write(b"\0" * (free - leave))
