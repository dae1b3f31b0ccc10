"""The embedded sample, made on request: a synthetic two-epoch urban scene (:mod:`.scene`).

An installed package holds no data files; it makes the sample's three LAZ files, the same byte
for byte on every machine, quickly (docs/performance.md). The repository's ``data_samples/`` holds the same
files (a test checks it), so the README's first command runs alike from a clone and from an
installed package:

>>> import lidar_sig.data                                  # doctest: +SKIP
>>> lidar_sig.data.write_sample("data_samples")            # doctest: +SKIP
[SampleFile('data_samples/epoch1.laz', 41,507 points, already there), ...]
"""
from __future__ import annotations

import io
import os
from dataclasses import dataclass
from pathlib import Path

from ..base.errors import LidarSigError, arg, as_path

#: The sample's files, in the order they are written.
SAMPLE_FILES = ("epoch1.laz", "epoch2.laz", "epoch2_aligned.laz")


@dataclass(frozen=True)
class SampleFile:
    """One file of the sample: its path, its number of points and whether it was written now
    (False: a file with the same bytes was already there)."""

    path: Path
    points: int
    written: bool

    def __repr__(self) -> str:
        return f"SampleFile({str(self.path)!r}, {self.points:,} points, {'written' if self.written else 'already there'})"


def write_sample(folder: str | Path, *, overwrite: bool = False) -> list[SampleFile]:
    """Write the sample's LAZ files (:data:`SAMPLE_FILES`) into ``folder``, made if missing
    (its parent must exist). A file already there with the same bytes is left as it is; one
    that differs is refused unless ``overwrite``. All files are written, or none."""
    from ..io import atomic_output, output_group
    from ._scene import sample_las

    folder = as_path(folder, "write_sample's folder")
    if folder.is_symlink() and not folder.exists():
        raise LidarSigError(f"is a link to {os.readlink(folder)}, which does not exist; give a folder for the "
                            "sample, or make the one it links to", path=folder)
    if folder.exists() and not folder.is_dir():
        raise LidarSigError("is a file, not a folder; give a folder for the sample", path=folder)
    if not folder.exists() and not folder.parent.is_dir():
        raise LidarSigError("the folder's parent does not exist; create it first", path=folder)
    made = {}
    for name, las in sample_las().items():
        buffer = io.BytesIO()
        las.write(buffer, do_compress=True)
        made[name] = (buffer.getvalue(), len(las.points))
    todo = {}
    for name, (data, _) in made.items():
        path = folder / name
        if path.is_file() and path.read_bytes() == data:
            continue
        if path.is_dir():  # not replaced, even with overwrite: it may hold anything
            raise LidarSigError("is a folder where the sample writes a file; move it away, or give another folder",
                                path=path)
        if (path.exists() or path.is_symlink()) and not overwrite:
            raise LidarSigError(f"exists and is not the sample's file; pass {arg('overwrite', True)} to "
                                "replace it, or give another folder", path=path)
        todo[name] = data
    from ..io.atomic import os_errors

    created = not folder.exists()
    with os_errors(folder):
        folder.mkdir(exist_ok=True)
    try:
        with output_group():
            for name, data in todo.items():
                with atomic_output(folder / name, overwrite=overwrite) as tmp:
                    tmp.write_bytes(data)
    except BaseException:
        if created and not any(folder.iterdir()):
            folder.rmdir()
        raise
    return [SampleFile(folder / name, points, name in todo) for name, (_, points) in made.items()]
