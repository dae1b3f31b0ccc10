"""The files of a set and their staging: every point read once, in chunks, and filed by cell.

A set is one or more LAS/LAZ files (folders stand for the files in them). Each file is read in
parts of at most ``PART_POINTS`` points, each part with ``laspy.open(...).chunk_iterator``, so
a file of any size is never held whole. Every point is appended to the staging file of its
plan-view cell (a square of the tile size, in the files' coordinate units) in a work folder;
a processing tile then loads the few cells its block touches. A point's identifier packs its
file (``source``) and its index in the file: ``source << ID_BITS | index``.

Withheld and noise points (``noise_codes``, :func:`lidar_sig.method.cloud.kept_points`) are counted
and not staged: the tiles never see them, as the single-block run does not.

A part is staged completely or not at all: its cell files are written in a folder of their
own, and the part's record (points, those left out, bounds of the others, labels, the file's
size and time, the rule that left points out) is written last.
"""
from __future__ import annotations

import json
import math
import os
import shutil
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..numerics.bounds import bounds
from ..method.cloud import MAX_COORDINATE, check_magnitude, kept_points
from ..base.errors import LidarSigError, arg, as_path, counted, reason, special_file
from ..io import LAS_EXTENSIONS
from ..numerics.records import join, pick
from ..numerics.sorting import stable_order
from ..io.tile_lists import check_distinct, tile_list
from .work import STAGED, read_record

#: Bits of a point identifier that hold its index in its file (files up to 10^12 points).
ID_BITS = 40
#: Points of one staging part (a unit of work: one file's range of points).
PART_POINTS = 4_000_000
#: Points per chunk read by laspy (bounds the memory of staging).
CHUNK_POINTS = 500_000
#: One staged point: raw coordinates (file units), class code, identifier.
RECORD = np.dtype([("x", "f8"), ("y", "f8"), ("z", "f8"), ("label", "i8"), ("id", "i8")])


def expand(inputs: Iterable[str | os.PathLike[str]], *, distinct: bool = True) -> list[Path]:
    """The LAS/LAZ files of ``inputs`` (files, folders, glob patterns and ``.vpc`` files,
    :func:`lidar_sig.io.tile_lists.tile_list`; a folder's files sorted by name). With
    ``distinct`` (a set whose points are joined), a tile given twice, under any name or as a
    copy, is refused (:func:`~lidar_sig.io.tile_lists.check_distinct`); a survey catalogue, whose
    tiles stay apart, names its copies instead."""
    files = []
    for given in inputs:
        p = as_path(given, "the inputs")
        listed = tile_list(p)  # a glob pattern of tiles, or a .vpc
        if listed is not None:
            for q in listed:
                if q.suffix.lower() not in LAS_EXTENSIONS:
                    raise NotLasSet(f"lists {q.name}; a set of tiles is read from LAS/LAZ files only", path=p)
            files += listed
        elif p.is_dir():
            found = sorted(q for q in p.iterdir() if q.is_file() and q.suffix.lower() in LAS_EXTENSIONS)
            if not found:
                raise NotLasSet("the folder holds no .las or .laz file; give a folder of LAS/LAZ tiles", path=p)
            files += found
        elif p.is_file():
            if p.suffix.lower() not in LAS_EXTENSIONS:
                raise NotLasSet("a set of tiles is read from LAS/LAZ files only; convert it, or give it alone "
                                    f"without {arg('tile_size')}, {arg('workers')} or {arg('scheduler')}", path=p)
            files.append(p)
        elif special_file(p):
            raise LidarSigError(f"is {special_file(p)}, not a regular file; give LAS/LAZ files or folders", path=p)
        else:
            raise LidarSigError("no such file or folder; check the path", path=p)
    if distinct:
        check_distinct(files)  # a tile given twice, under any name or as a copy, would count twice
    return [f.resolve() for f in files]


class NotLasSet(LidarSigError):
    """Inputs that hold a file other than LAS/LAZ: no set of tiles (one block may read them)."""


@dataclass(frozen=True, repr=False)
class Source:
    """One file of the set as its header describes it (``error`` set when it cannot be read)."""

    id: int
    path: str
    n_points: int = 0
    lo: tuple = ()
    hi: tuple = ()
    factors: tuple = ()
    crs: str | None = None
    units: str = ""
    error: str | None = None

    @property
    def name(self):
        return Path(self.path).name

    def __repr__(self):
        from ..method.crs import crs_name
        from ..base.views import one_line

        said = f"unreadable: {self.error}" if self.error else (
            f"{self.n_points:,} points, {crs_name(self.crs) or 'no CRS'}")
        return one_line(f"<Source {self.id}: {self.name}, {said}>")

    def parts(self, workers=1):
        """(start, stop) point ranges staged as separate units of work: at most PART_POINTS
        points, and a file split among ``workers`` (not below CHUNK_POINTS a part)."""
        n, workers = self.n_points, max(1, workers)
        # as many parts as it takes of PART_POINTS, made a multiple of the workers so that none
        # waits on a last part alone (5 parts on 2 workers took the time of 3)
        count = workers * math.ceil(math.ceil(n / PART_POINTS) / workers)
        step = max(CHUNK_POINTS, math.ceil(n / count))
        return [(s, min(n, s + step)) for s in range(0, n, step)]


def scan(files: Iterable[str | os.PathLike[str]]) -> list[Source]:
    """A :class:`Source` per file from its header; files whose header cannot be read get the
    reason in ``error``. Refuses a set whose readable files are in different CRS, and a file
    without points (its header's bounds would stretch the set's extent to meaningless values)."""
    import laspy

    from ..method.crs import las_units, same_crs

    sources = []
    for i, f in enumerate(files):
        try:
            with laspy.open(f) as reader:
                h = reader.header
                crs, units = las_units(h, path=f)
                if int(h.point_count) == 0:
                    raise LidarSigError("holds no points; leave it out of the set", path=f)
                reach = float(np.max(np.abs([h.mins, h.maxs]) * np.asarray(units.factors)))
                if not reach <= MAX_COORDINATE:  # NaN too: the set's extent comes from the headers
                    sources.append(Source(i, str(f), error=f"its header's bounds reach {reach:.6g} m, beyond "
                                          f"{MAX_COORDINATE:g} m; correct the coordinates (the header's "
                                          "scale and offset)"))
                    continue
                sources.append(Source(i, str(f), int(h.point_count), tuple(map(float, h.mins)),
                                      tuple(map(float, h.maxs)), tuple(units.factors), crs,
                                      units.describe()))
        except LidarSigError:
            raise
        except Exception as exc:  # laspy raises many kinds on a damaged header
            sources.append(Source(i, str(f), error=f"cannot be read as LAS/LAZ ({reason(exc)})"))
    good = [s for s in sources if s.error is None]
    for s in good:
        if s.factors != good[0].factors:
            raise LidarSigError(f"uses other coordinate units ({s.factors} metres per unit) than "
                                f"{good[0].name} ({good[0].factors}); give a set in one CRS", path=s.path)
        if not same_crs(s.crs, good[0].crs):
            raise LidarSigError(f"is in another CRS than {good[0].name} ({'none' if s.crs is None else 'it differs'})"
                                "; give a set in one CRS", path=s.path)
    return sources


@dataclass(frozen=True)
class Cells:
    """The staging grid: square cells of ``side`` file units from ``origin`` (x, y); a quarter
    of the tile side, so that a tile and its halo read little beyond themselves."""

    origin: tuple
    side: float

    def record(self):
        """The grid as kept with each staged part (a part staged on another grid is not reused)."""
        return [float(self.origin[0]), float(self.origin[1]), float(self.side)]

    def of(self, x, y):
        """(N,) cell i and j of raw coordinates."""
        return (np.floor((x - self.origin[0]) / self.side).astype(np.int64),
                np.floor((y - self.origin[1]) / self.side).astype(np.int64))

    def covering(self, raw_bounds):
        """Every (i, j) whose cell meets the raw box (x0, y0, x1, y1)."""
        x0, y0, x1, y1 = raw_bounds
        eps = 1e-9 * self.side  # round-off of the conversion to file units
        i0, j0 = self.of(np.array([x0 - eps]), np.array([y0 - eps]))
        i1, j1 = self.of(np.array([x1 + eps]), np.array([y1 + eps]))
        return [(i, j) for i in range(int(i0[0]), int(i1[0]) + 1) for j in range(int(j0[0]), int(j1[0]) + 1)]


def part_dir(work, source_id, part):
    return Path(work) / STAGED / f"s{source_id}p{part}"


def part_record(work, source_id, part):
    return Path(work) / STAGED / f"s{source_id}p{part}.json"


def file_identity(path):
    """(size in bytes, modification time in ns): a file replaced since staging differs."""
    st = os.stat(path)
    return [st.st_size, st.st_mtime_ns]


def staged(work, source, part, start, stop, cells, noise_codes=None):
    """(record, None) of a part staged from the file as it is now, points [start, stop), on
    the grid ``cells``, leaving out the same points (``noise_codes``, as for
    :func:`stage_part`); else (None, why the part found there does not serve: a few words for a
    resumed run's note), or (None, None) where none is there."""
    info = read_record(part_record(work, source.id, part), work)
    if not isinstance(info, dict):
        return None, None  # none, or a damaged one (the work folder notes those)
    if info.get("path") != source.path:  # a file's number is its place in the set's list
        return None, "another file in its place: the set's files changed"
    if info.get("identity") != file_identity(source.path):
        return None, "edited since"
    if info.get("range") != [start, stop]:  # a file is cut into parts by the number of workers
        return None, "cut into other parts: another --workers"
    if info.get("grid") != cells.record():  # from the tile size (--tile-size, or --memory and --workers) and extent
        return None, "staged on another grid: another tile size or extent"
    if info.get("noise_codes", "?") != _codes_record(noise_codes):
        return None, "other points left out"
    return info, None


def _codes_record(noise_codes):
    return None if noise_codes is None else sorted(int(c) for c in noise_codes)


def stage_part(work, source, part, start, stop, cells, noise_codes=None):
    """Read points [start, stop) of ``source`` (its part number ``part``) in chunks and append
    each to its cell's file, except those withheld or of a class in ``noise_codes`` (None
    stages every point; :meth:`Pipeline.noise_codes`); return the part's record, which counts
    them (``n_excluded``), bounds the others (``lo``, ``hi``) and counts them per cell (``cells``,
    ``counts``). Raises LidarSigError naming the file when it cannot be read."""
    import laspy

    from ..io.las import las_xyz

    out = part_dir(work, source.id, part)
    shutil.rmtree(out, ignore_errors=True)  # an interrupted earlier attempt
    out.mkdir(parents=True)
    lo, hi = np.full(3, np.inf), np.full(3, -np.inf)
    n = n_excluded = 0
    labelled = False
    occupied = {}  # cell -> points staged in it
    try:
        with laspy.open(source.path) as reader:
            if start:
                reader.seek(start)
            for chunk in reader.chunk_iterator(min(CHUNK_POINTS, stop - start)):
                take = min(len(chunk), stop - start - n)
                if take <= 0:
                    break
                xyz = las_xyz(chunk, take)
                check_magnitude(xyz, source.factors, path=source.path, start=start + n)
                rec = np.empty(take, RECORD)
                rec["x"], rec["y"], rec["z"] = xyz[:, 0], xyz[:, 1], xyz[:, 2]
                rec["label"] = np.asarray(chunk.classification)[:take]
                rec["id"] = (np.int64(source.id) << ID_BITS) | np.arange(start + n, start + n + take)
                labelled |= bool(rec["label"].any())
                n += take
                kept = kept_points(rec["label"], np.asarray(chunk.withheld)[:take], noise_codes)
                if kept is not None:
                    n_excluded += int((~kept).sum())
                    rec, xyz = pick(rec, kept), xyz[kept]
                if not len(rec):
                    continue
                part_lo, part_hi = bounds(xyz)
                lo, hi = np.minimum(lo, part_lo), np.maximum(hi, part_hi)
                ci, cj = cells.of(xyz[:, 0], xyz[:, 1])
                order = _by_cell(ci, cj)
                ci, cj, rec = ci[order], cj[order], pick(rec, order)
                breaks = np.flatnonzero((np.diff(ci) != 0) | (np.diff(cj) != 0)) + 1
                for s, e in zip(np.r_[0, breaks], np.r_[breaks, len(rec)]):
                    key = (int(ci[s]), int(cj[s]))
                    occupied[key] = occupied.get(key, 0) + int(e - s)
                    try:  # a write of Python's, which says why it failed (tofile: "6740 requested and 102 written")
                        with open(out / f"c{key[0]}_{key[1]}.bin", "ab") as fh:
                            fh.write(rec[s:e].tobytes())
                    except OSError as exc:  # the work folder's disk (full, read-only), not the input, failed
                        raise LidarSigError(f"cannot stage {source.name} ({exc.strerror or reason(exc)}); free space "
                                            f"or give another {arg('work_dir')}", path=out.parent.parent) from None
    except LidarSigError:
        raise
    except OSError as exc:  # the work folder's disk (full, read-only), not the input, failed
        if exc.filename is not None and str(exc.filename).startswith(str(out)):
            raise LidarSigError(f"cannot stage {source.name} ({exc.strerror}); free space or give another "
                                f"{arg('work_dir')}", path=out.parent.parent) from None
        raise LidarSigError(f"cannot be read ({reason(exc)})", path=source.path) from None
    except Exception as exc:  # laspy and lazrs raise many kinds on damaged input
        raise LidarSigError(f"cannot be read as LAS/LAZ after {counted(start + n, 'point')} ({reason(exc)}); check "
                            "that the file is complete", path=source.path) from None
    if n != stop - start:
        raise LidarSigError(f"holds {counted(start + n, 'point')} but its header says {source.n_points:,}; the file is "
                            "truncated", path=source.path)
    info = {"path": source.path, "identity": file_identity(source.path), "range": [start, stop], "n": n,
            "n_excluded": n_excluded, "noise_codes": _codes_record(noise_codes), "grid": cells.record(),
            "lo": lo.tolist(),
            "hi": hi.tolist(), "labelled": labelled, "cells": sorted(occupied),
            "counts": [occupied[key] for key in sorted(occupied)]}
    if part == 0:
        from ..io.archive import sha256_of

        info["sha256"] = sha256_of(source.path)
    tmp = part_record(work, source.id, part).with_suffix(".tmp")
    tmp.write_text(json.dumps(info))
    os.replace(tmp, part_record(work, source.id, part))  # the part exists only once complete
    return info


def _by_cell(ci, cj):
    """The order that sorts points by staging cell (i, then j), each cell's points in their
    order: one stable sort of one key (by radix where a chunk's few cells allow)."""
    di, dj = ci - ci.min(initial=0), cj - cj.min(initial=0)
    span = int(dj.max(initial=0)) + 1
    key = di * span + dj
    return stable_order(key)


def densest(records, cells, factors):
    """Points per square metre of the most crowded staging cell over the parts ``records``:
    where a tile holds the most points (the headers' bounding box can hide a dense strip)."""
    per_cell = {}
    for info in records.values():
        for key, n in zip(info["cells"], info.get("counts", ())):
            per_cell[tuple(key)] = per_cell.get(tuple(key), 0) + n
    area = (cells.side * factors[0]) * (cells.side * factors[1])
    return max(per_cell.values(), default=0) / area


def cell_files(work, records):
    """{(i, j): [staging files]} over the staged parts ``records`` ({(source, part): record})."""
    files = {}
    for (sid, part), info in records.items():
        for i, j in info["cells"]:
            files.setdefault((i, j), []).append(str(part_dir(work, sid, part) / f"c{i}_{j}.bin"))
    return files


def load_cells(files, cells, raw_bounds):
    """The staged points (structured RECORD array) within the raw box, from ``files``."""
    x0, y0, x1, y1 = raw_bounds
    eps = 1e-9 * cells.side  # round-off of the conversion to file units; the caller cuts exactly
    parts = []
    for key in cells.covering(raw_bounds):
        # a cell inside the box is taken whole: most of a tile's cells, whose points the test
        # would only copy (the cell of a point is its floor, so its points lie within the
        # cell's bounds up to round-off far below eps)
        cx0, cy0 = cells.origin[0] + key[0] * cells.side, cells.origin[1] + key[1] * cells.side
        whole = x0 <= cx0 and cx0 + cells.side <= x1 and y0 <= cy0 and cy0 + cells.side <= y1
        for f in files.get(key, ()):
            rec = np.fromfile(f, RECORD)
            if not whole:
                inside = ((rec["x"] >= x0 - eps) & (rec["x"] <= x1 + eps) & (rec["y"] >= y0 - eps)
                          & (rec["y"] <= y1 + eps))
                rec = pick(rec, inside)
            parts.append(rec)  # one cell file at a time in memory, then its share
    return join(parts, RECORD)


def source_of(ids):
    """File number of point identifiers."""
    return np.asarray(ids) >> ID_BITS


def tile_side_for(points_per_tile, density):
    """Tile side (metres) holding about ``points_per_tile`` points at ``density`` per m²."""
    return math.sqrt(points_per_tile / max(density, 1e-12))
