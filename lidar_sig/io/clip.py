"""Clouds clipped to an area of interest (:mod:`lidar_sig.io.aoi`) before anything is computed,
reading only what the area needs.

Every input (a file, a folder, a glob pattern, a ``.vpc``, local or an ``http(s)://`` URL) is
replaced by its clipped copy in a scratch folder: a file by a LAS/LAZ file of the same name
holding the points inside the area, a set of tiles by a folder of such files (tiles left with
no point are left out). A tile whose bounds miss the area is not opened beyond its header (a
``.vpc`` feature's bounds are read first, and such a tile is not opened at all), so a damaged
tile outside the area does not stop the run. A COPC file is queried by the area's bounds
(its octree's nodes that meet them, read by byte range); a plain LAS/LAZ file that meets the
area is read in chunks and filtered. The run is then the run of the clipped clouds: halos,
densities and the change map's level of detection see only the points of the area.

What was read is counted in a :class:`Reading`: files opened, files skipped by their bounds,
points read and kept, COPC nodes and bytes read.
"""
from __future__ import annotations

import copy
import os
import re
import shutil
import tempfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..base.errors import LidarSigError, arg, counted, reason
from .aoi import Area, area_of
from .formats import LAS_EXTENSIONS
from .remote import is_url, open_input, url_name

#: Points per chunk of a plain LAS/LAZ file read while clipping.
CHUNK_POINTS = 500_000


@dataclass
class Reading:
    """What clipping read: ``files`` opened beyond their header, ``skipped`` (names of files
    whose bounds miss the area), ``points`` read and ``kept``, COPC ``nodes`` fetched and
    ``bytes`` read (local and remote), and ``remote`` bytes fetched over HTTP."""

    area: str = ""
    files: int = 0
    skipped: list[str] = field(default_factory=list)
    points: int = 0
    kept: int = 0
    nodes: int = 0
    bytes: int = 0
    remote: int = 0

    def to_dict(self) -> dict[str, Any]:
        return {"area": self.area, "files_read": self.files, "files_skipped": list(self.skipped),
                "points_read": self.points, "points_kept": self.kept, "copc_nodes": self.nodes,
                "bytes_read": self.bytes, "bytes_fetched": self.remote}

    def line(self) -> str:
        """One line for a summary: the area, what was read and skipped."""
        nodes = f", {counted(self.nodes, 'COPC node')}" if self.nodes else ""
        fetched = f" ({size(self.remote)} over HTTP)" if self.remote else ""
        return (f"area of interest {self.area}: {counted(self.kept, 'point')} inside, read from "
                f"{counted(self.files, 'file')}{nodes}, {size(self.bytes)} read{fetched}; "
                f"{counted(len(self.skipped), 'file')} outside skipped by their bounds")


def size(n: int) -> str:
    """A number of bytes for people: 512 B, 40.2 kB, 3.1 MB, 2.0 GB (powers of 1000)."""
    for unit, scale in (("GB", 1e9), ("MB", 1e6), ("kB", 1e3)):
        if n >= scale:
            return f"{n / scale:.1f} {unit}"
    return f"{n} B"


class Clipped:
    """The inputs of a job clipped to an area (:func:`clip_inputs`): ``inputs`` in the shape
    given, each path replaced by its clipped copy in a scratch folder, ``reading`` what was read
    (None when nothing was clipped or fetched); the folder goes with :meth:`cleanup` or at the
    end of a ``with`` block."""

    def __init__(self, inputs: list[Any], reading: Reading | None, scratch: Path | None) -> None:
        self.inputs, self.reading, self._scratch = inputs, reading, scratch

    def shown(self, line: str) -> str:
        """``line`` with the scratch folder's paths shown as the inputs' names."""
        if self._scratch is None:
            return line
        return re.sub(re.escape(f"{self._scratch}{os.sep}") + r"i\d+_\d+" + re.escape(os.sep), "", line)

    def cleanup(self) -> None:
        if self._scratch is not None:
            shutil.rmtree(self._scratch, ignore_errors=True)

    def __enter__(self) -> Clipped:
        return self

    def __exit__(self, *exc: object) -> None:
        self.cleanup()


def clip_inputs(inputs: list[Any], aoi: Any, folder: str | os.PathLike[str] | None = None) -> Clipped:
    """Each input (a path, or a list of paths: e.g. an epoch's tiles) replaced by its clipped
    copy, in a scratch folder made in ``folder`` (default: the system's temporary folder);
    without an area, only inputs read from a web server are fetched into it (whole). Refuses in
    one line an area that misses every cloud."""
    area = area_of(aoi)
    groups = [list(i) if isinstance(i, (list, tuple)) else [i] for i in inputs]
    if area is None and not any(_remote(str(text)) for group in groups for text in group):
        return Clipped(list(inputs), None, None)
    for group in groups:
        for text in group:
            if not isinstance(text, (str, os.PathLike)):
                raise LidarSigError(f"{arg('aoi')} clips LAS/LAZ/COPC files and URLs, not {type(text).__name__}; "
                                    "give the inputs as paths")
    from ..base.progress import step

    scratch = Path(tempfile.mkdtemp(prefix="lidar-sig-aoi-", dir=folder))
    try:
        reading = Reading(area=area.said if area is not None else "")
        clipper = _Clipper(area, reading)
        out = []
        with step("reading the area of interest" if area is not None else "fetching the inputs") as shown:
            clipper.shown = shown
            kept_groups = [[clipper.input(str(text), scratch / f"i{g}_{k}") for k, text in enumerate(group)]
                           for g, group in enumerate(groups)]
        for group, made in zip(groups, kept_groups):
            kept = [k for k in made if k is not None]
            if not kept:
                raise LidarSigError(f"the area of interest {area.said if area else ''} misses every cloud of this "
                                    f"input ({clipper.extent()}); give an area in the clouds' CRS that meets "
                                    "them", path=str(group[0]))
            out.append(kept)
        if area is not None:
            reading.area = clipper.described()
    except BaseException:
        shutil.rmtree(scratch, ignore_errors=True)
        raise
    shaped: list[Any] = [o if isinstance(i, (list, tuple)) else o[0] for i, o in zip(inputs, out)]
    return Clipped(shaped, reading, scratch)


def clip_cloud(cloud: Any, aoi: Any) -> tuple[Any, str]:
    """(the PointCloud of ``cloud`` inside the area, the area described): a LAS/LAZ/COPC path
    or URL is clipped as it is read (:func:`clip_inputs`), a PointCloud in memory filtered."""
    from ..method.cloud import PointCloud

    if isinstance(cloud, PointCloud):
        given = area_of(aoi)
        assert given is not None
        area = given.in_crs(cloud.crs)
        keep = area.contains(cloud.xyz[:, 0], cloud.xyz[:, 1])
        if not keep.any():
            raise LidarSigError(f"the area of interest {area.describe()} holds none of the cloud's points; give an "
                                "area that meets it")
        return cloud.subset(keep), area.describe()
    from . import read

    with clip_inputs([cloud], aoi) as clip:
        assert clip.reading is not None
        return read(clip.inputs[0]), clip.reading.area


def clip_file(source: str, out: Path, area: Area | None, reading: Reading, crs_of: Any = None) -> bool:
    """Write the points of the LAS/LAZ/COPC file or URL ``source`` inside ``area`` (every point
    without one) to ``out``; False, with nothing written, when the file's bounds miss the area or
    no point is inside. ``crs_of(wkt)`` gives the area in a file's CRS."""
    with open_input(source) as fh:
        try:
            return _clip_open(fh, source, out, area, reading, crs_of)
        except LidarSigError:
            raise
        except OSError as exc:
            if exc.filename is not None and str(exc.filename).startswith(str(out.parent)):
                raise LidarSigError(f"cannot write the clipped copy of {_name(source)} ({exc.strerror}); free space "
                                    "or point TMPDIR at a folder with room", path=out.parent) from None
            raise LidarSigError(f"cannot be read ({reason(exc)})", path=source) from None
        except Exception as exc:  # laspy and lazrs raise many kinds on damaged input
            raise LidarSigError(f"cannot be read as LAS/LAZ ({reason(exc)}); check that the file is complete",
                                path=source) from None
        finally:  # what was read, the header of a file skipped by its bounds too
            reading.bytes += fh.bytes_read
            reading.remote += fh.bytes_read if fh.remote else 0


def _clip_open(fh, source, out, area, reading, crs_of):
    """:func:`clip_file` of the opened input ``fh``."""
    import laspy

    from ..method.crs import las_units
    with laspy.open(fh, closefd=False) as reader:
        header = reader.header
        crs, _ = las_units(header, path=source)
        here = crs_of(crs, header.mins, header.maxs) if area is not None else None
        if here is not None and not here.meets(header.mins, header.maxs):
            reading.skipped.append(_name(source))
            return False
        reading.files += 1
        if here is None or not any(v.user_id == "copc" for v in header.vlrs):
            return _write(out, header, _chunks(reader, here, reading), reading)
    return _write(out, header, _copc_query(fh, here, reading), reading)


def _chunks(reader, area, reading):
    for chunk in reader.chunk_iterator(CHUNK_POINTS):
        reading.points += len(chunk)
        if area is None:
            yield chunk
        else:
            yield chunk[area.contains(np.asarray(chunk.x), np.asarray(chunk.y))]


def _copc_query(fh, area, reading):
    """The points of a COPC file in the area: its nodes that meet the area's bounds, filtered."""
    import laspy
    from laspy.copc import Bounds, load_octree_for_query

    fh.seek(0)
    reader = laspy.CopcReader(fh, close_fd=False)
    x0, y0, x1, y1 = area.bounds
    bounds = Bounds(mins=np.array([x0, y0]), maxs=np.array([x1, y1])).ensure_3d(reader.header.mins,
                                                                                reader.header.maxs)
    reading.nodes += len(load_octree_for_query(reader.source, reader.copc_info, reader.root_page,
                                               query_bounds=bounds, level_range=None))
    points = reader.query(bounds=bounds)
    reading.points += len(points)
    yield points[area.contains(np.asarray(points.x), np.asarray(points.y))]


def _write(out, header, chunks, reading):
    """Write the chunks under ``header`` (its COPC records dropped) to ``out``; False when no
    point was kept (nothing written)."""
    import laspy

    from .las import drop_copc, without_copc

    header = copy.deepcopy(header)
    drop_copc(header)
    evlrs = without_copc(header.evlrs or [])  # a VLRList, as the writer takes
    writer = None
    try:
        for chunk in chunks:
            if not len(chunk):
                continue
            if writer is None:
                out.parent.mkdir(parents=True, exist_ok=True)
                writer = laspy.open(out, mode="w", header=header,
                                    do_compress=out.suffix.lower() == ".laz")
            writer.write_points(chunk)
            reading.kept += len(chunk)
        if writer is not None and evlrs:
            writer.write_evlrs(evlrs)
    finally:
        if writer is not None:
            writer.close()
    return writer is not None


class _Clipper:
    """Inputs replaced by their clipped copies, the area resolved once per CRS."""

    def __init__(self, area: Area | None, reading: Reading):
        self.area, self.reading = area, reading
        self.shown: Any = None  # the progress step: bytes read so far after each file
        self._in: dict[Any, Area] = {}
        self._lo = np.full(2, np.inf)
        self._hi = np.full(2, -np.inf)

    def crs_of(self, crs, lo=None, hi=None):
        """The area in the CRS ``crs`` of a file whose bounds are ``lo``, ``hi`` (kept for messages)."""
        if lo is not None:
            self._seen(lo[:2], hi[:2])
        key = crs or ""
        if key not in self._in:
            self._in[key] = self.area.in_crs(crs)
        return self._in[key]

    def described(self):
        resolved = next(iter(self._in.values()), self.area)
        return resolved.describe()

    def extent(self):
        if not np.isfinite(self._lo).all():
            return "no file meets it"
        return (f"they span {self._lo[0]:.2f},{self._lo[1]:.2f},{self._hi[0]:.2f},{self._hi[1]:.2f}; "
                f"the area is {self.described()}")

    def input(self, text: str, out: Path) -> str | None:
        """The clipped copy of one input: a file, or a folder of the clipped tiles a folder, a
        glob pattern or a .vpc lists; None when the area holds none of its points."""
        from .tile_lists import tile_list, vpc_tiles

        if self.area is None and not _remote(text):
            return text  # local, and nothing to clip: read where it is
        if _is_vpc(text):
            tiles = vpc_tiles(text)
        elif is_url(text):
            tiles = None
        else:
            listed = tile_list(text)
            p = Path(text)
            if listed is not None:
                tiles = [(str(q), None) for q in listed]
            elif p.is_dir():
                tiles = [(str(q), None) for q in sorted(p.iterdir())
                         if q.is_file() and q.suffix.lower() in LAS_EXTENSIONS]
            else:
                tiles = None
        if tiles is None:  # one file
            self._las_only(text)
            target = out / _name(text)
            return str(target) if self._one(text, target, None) else None
        names: set[str] = set()
        kept = 0
        for k, (tile, box) in enumerate(tiles):
            self._las_only(tile)
            name = _name(tile)
            if name in names:
                name = f"{k}_{name}"
            names.add(name)
            kept += self._one(tile, out / name, box)
        return str(out) if kept else None

    def _one(self, tile, target, box):
        """Clip one tile; ``box`` its bounds from a .vpc (x0, y0, x1, y1, CRS), read first."""
        if self.area is not None and box is not None:
            x0, y0, x1, y1, crs = box
            self._seen((x0, y0), (x1, y1))
            if not self.crs_of(crs).meets((x0, y0), (x1, y1)):
                self.reading.skipped.append(_name(tile))
                return False
        before = len(self.reading.skipped)
        done = clip_file(tile, target, self.area, self.reading, self.crs_of)
        if self.shown is not None:
            self.shown.note(bytes_read=self.reading.bytes, bytes_fetched=self.reading.remote)
            self.shown.postfix(f"{size(self.reading.bytes)} read, {size(self.reading.remote)} fetched")
        if self.area is not None and len(self.reading.skipped) > before:
            return False
        return done

    def _seen(self, lo, hi):
        self._lo = np.minimum(self._lo, lo)
        self._hi = np.maximum(self._hi, hi)

    def _las_only(self, text):
        if Path(url_name(text)).suffix.lower() not in LAS_EXTENSIONS:
            raise LidarSigError(f"{arg('aoi')} and URLs take LAS/LAZ/COPC inputs; clip this input beforehand or "
                                f"leave out {arg('aoi')}", path=text)


def _remote(text: str) -> bool:
    """Whether an input is read from a web server: a URL, or a .vpc listing URLs."""
    from .tile_lists import vpc_tiles

    if is_url(text):
        return True
    return _is_vpc(text) and Path(text).is_file() and any(is_url(href) for href, _ in vpc_tiles(text))


def _is_vpc(text: str) -> bool:
    return url_name(text).lower().endswith(".vpc")


def _name(text: str) -> str:
    return Path(url_name(text)).name
