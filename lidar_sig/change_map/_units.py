"""Work units of a change map at survey scale (docs/changes.md, "At survey scale"): the tasks
that turn two epochs' tiled saliency runs (:func:`lidar_sig.tiling.run_set.run_set`) into the
cells' metrics and the sampling part of their level of detection, each holding a bounded share
of the points.

1. :func:`density_task`, per processing tile: the 10 m pixels its points occupy, from which
   each epoch's density (and so the cell size and the fewest points) follows as in one block.
2. :func:`code_task`, per processing tile: each core point coded once (its cell, key,
   pixel in the cell frame, Egeom bin, class and height) and filed by work unit, a square block
   of cells; a thinned sample of its points is kept for the report's top view.
3. :func:`unit_task`, per work unit: its cells' points of both epochs, ordered by cell and then
   by key (:func:`~lidar_sig.change_map._cells.point_keys`: the order of a cell's points in the
   one-block run, whatever the files), the signatures' metrics and the resamples, each cell drawing from its own random
   stream; what it returns depends only on the points of its cells, so the cells of a unit
   get the values of the one-block run.

The survey part of the level of detection is a statistic over every cell of the map: the main
process computes it once the units are done (:mod:`~lidar_sig.change_map._in_units`). Every
file is written whole or not at all, with the key of what it was computed from, so that a
resumed run reuses it.
"""
from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..method.saliency_map import geometric_entropy
from ..method.signature_raster import Frame, point_codes
from ..numerics.records import join, pick
from ..numerics.sorting import stable_order
from ..tiling.work import UNITS, load_done, save_whole
from ._cells import CHANGE_KEYS, Binned, null_metrics, observed_metrics
from ._density import DENSITY_PIXEL, occupied_pixels

#: One coded point of a work unit: its flat cell on the map's grid, its key
#: (:func:`~lidar_sig.change_map._cells.point_keys`: the order of a cell's points), its codes in a
#: cell's signature (:func:`lidar_sig.method.signature_raster.point_codes`) and its height in
#: metres.
#: 32 bytes (48 when every field was 64-bit): a grid holds at most
#: :data:`~lidar_sig.change_map._grid.MAX_CELLS` cells (32 bits), an Egeom bin and a class index
#: fit 16 bits; a pixel code of a large frame and class table needs 64.
CODED = np.dtype([("cell", "i4"), ("key", "u8"), ("pixel", "i8"), ("egeom", "i2"), ("cls", "i2"),
                  ("height", "f8")])
#: Bytes a work unit holds per point of its cells (both epochs): the coded records, their
#: order, the binned arrays and the drawn resamples (docs/performance.md has the measurement).
UNIT_BYTES_PER_POINT = 240
#: Points of the thinned sample that draws the report's top view of an epoch (in all).
VIEW_POINTS = 1_000_000
#: One point of that sample: raw coordinates and saliency.
VIEW = np.dtype([("x", "f8"), ("y", "f8"), ("z", "f8"), ("values", "f8", 3)])


@dataclass(frozen=True)
class UnitPlan:
    """Everything the tasks of a change map in work units share (small: pickled to each
    worker): the work folder, the map's grid, the side of a unit in cells, the signatures'
    frame and class table, whether the epochs are labelled, and each epoch's tiled run
    (:class:`lidar_sig.tiling.SetRun`)."""

    work: str
    grid: object
    side: int
    frame: Frame
    classes: object
    labelled: bool
    epochs: tuple
    min_points: int = 1
    render: str = "smooth"
    seed: int = 17
    stream: int = 0

    @property
    def shape(self):
        """Work units along the grid's rows and columns."""
        return math.ceil(self.grid.rows / self.side), math.ceil(self.grid.cols / self.side)

    @property
    def n_units(self):
        return math.prod(self.shape)

    def unit_of(self, cells):
        """(N,) the work unit of each flat cell."""
        row, col = np.divmod(np.asarray(cells), self.grid.cols)
        return (row // self.side) * self.shape[1] + col // self.side

    def cells_of(self, unit):
        """The flat cells of work ``unit``, ascending."""
        ur, uc = divmod(int(unit), self.shape[1])
        rows = np.arange(ur * self.side, min((ur + 1) * self.side, self.grid.rows))
        cols = np.arange(uc * self.side, min((uc + 1) * self.side, self.grid.cols))
        return (rows[:, None] * self.grid.cols + cols[None, :]).ravel()

    def key(self, epoch=None):
        """Changes whenever a coded tile (of ``epoch``) or a unit's result would."""
        runs = [r.plan.key() for r in self.epochs] if epoch is None else [self.epochs[epoch].plan.key()]
        return json.dumps([runs, repr(self.grid), self.side, self.frame.size, self.frame.margin, repr(self.classes),
                           self.labelled, self.min_points, self.render, self.seed, self.stream], default=str)




def density_task(run, ij, lo, pixel):
    """(pixels,) int64 keys of the ``pixel``-sided squares from the corner ``lo`` (raw units)
    that the staged points of tile ``ij``'s box of an epoch's tiled ``run`` occupy: over every
    tile, those of all its points (:func:`lidar_sig.change_map._density.density`)."""
    # the points of the tile's box, a few of its neighbours' among them: the union over the
    # tiles is the same, and the core is not worth sorting out here
    rec = run.box_points(ij)
    ij_px = np.column_stack([np.floor((rec["x"] - lo[0]) / pixel), np.floor((rec["y"] - lo[1]) / pixel)])
    return occupied_pixels(ij_px.astype(np.int64))


def density_pixel(units_horizontal):
    """The side of the density's pixels in the CRS's units."""
    return DENSITY_PIXEL / units_horizontal


def coded_path(work, epoch, ij):
    return Path(work) / "coded" / f"e{epoch}" / f"t{ij[0]}_{ij[1]}.npz"


def points_path(coded):
    """The coded points of the tile whose index is ``coded`` (:func:`coded_path`)."""
    return coded.with_name(coded.stem + ".points.npy")


def view_path(work, epoch, ij):
    return Path(work) / "view" / f"e{epoch}" / f"t{ij[0]}_{ij[1]}.npy"


def code_task(uplan, epoch, ij, view_step):
    """Code tile ``ij``'s core points of ``epoch`` (:data:`CODED`), sorted by work unit, into the
    work folder with the units they reach and where each starts; keep every ``view_step``-th
    point for the top view. Returns {unit: points} of the tile."""
    path = coded_path(uplan.work, epoch, ij)
    key = uplan.key(epoch)
    done = load_done(path, key, uplan.work, extra=(points_path(path), view_path(uplan.work, epoch, ij)))
    if done is not None:
        return dict(zip(done["units"].tolist(), np.diff(done["starts"]).tolist()))
    run = uplan.epochs[epoch]
    kept = run.sample_points(ij)  # of the epoch's sample, the points its cells take
    raw, values = np.column_stack([kept["x"], kept["y"], kept["z"]]), kept["values"]
    codes = kept["label"] if uplan.labelled else np.zeros(len(kept), np.int64)
    cls = uplan.classes.index(codes)
    pixel, egeom_bin = point_codes(values, cls, uplan.frame, egeom=geometric_entropy(values))
    rec = np.empty(len(kept), CODED)
    rec["cell"] = uplan.grid.cell_of(raw[:, :2])
    rec["key"] = kept["key"]
    rec["pixel"], rec["egeom"], rec["cls"] = pixel, egeom_bin, cls
    rec["height"] = raw[:, 2] * run.ctx.factors[2]
    unit = uplan.unit_of(rec["cell"])
    order = stable_order(unit)
    rec, unit = pick(rec, order), unit[order]
    starts = np.flatnonzero(np.r_[True, unit[1:] != unit[:-1]]) if len(unit) else np.empty(0, np.int64)
    units = unit[starts]
    starts = np.r_[starts, len(rec)]
    thin = slice(None, None, max(1, int(view_step)))
    view = np.empty(len(raw[thin]), VIEW)
    view["x"], view["y"], view["z"] = raw[thin].T
    view["values"] = values[thin]
    save_whole(view_path(uplan.work, epoch, ij), view)
    save_whole(points_path(path), rec)  # a file of its own: a unit maps the slice it needs, not the tile's points
    save_whole(path, units=units, starts=starts, key=np.array(key))  # last: the tile is coded
    return dict(zip(units.tolist(), np.diff(starts).tolist()))


def unit_points(uplan, epoch, unit, tiles):
    """The coded points of ``epoch`` in work ``unit`` from the coded ``tiles`` that reach it,
    ordered by cell and then key."""
    parts = []
    for ij in tiles:
        path = coded_path(uplan.work, epoch, ij)
        with np.load(path) as f:
            units, starts = f["units"], f["starts"]
        k = int(np.searchsorted(units, unit))
        if k < len(units) and units[k] == unit:
            mapped = np.load(points_path(path), mmap_mode="r")
            parts.append(np.array(mapped[starts[k]:starts[k + 1]]))
            del mapped  # unmapped: the pages read leave the process
    rec = join(parts, CODED)
    # np.lexsort((key, cell)) as two stable radix sorts: by key, then by cell
    by_key = stable_order(rec["key"])
    cell = rec["cell"][by_key]
    return pick(rec, by_key[stable_order(cell - cell.min() if len(cell) else cell)])  # the unit's few cells: 16 bits


def binned_unit(rec, cells, n_classes):
    """The :class:`~lidar_sig.change_map._cells.Binned` of a unit's coded points ``rec`` (ordered
    by cell) on its flat ``cells``."""
    local = np.searchsorted(cells, rec["cell"])
    n = len(cells)
    starts = np.searchsorted(local, np.arange(n + 1))
    counts = np.bincount(local * n_classes + rec["cls"], minlength=n * n_classes)[:n * n_classes]
    undefined = np.bincount(local[rec["pixel"] < 0], minlength=n)[:n]
    return Binned(np.arange(len(rec)), starts, counts.reshape(n, n_classes), undefined, rec["pixel"],
                  rec["egeom"], rec["cls"], rec["height"])


def unit_path(work, unit):
    return Path(work) / UNITS / f"u{int(unit)}.npz"


def unit_task(uplan, unit, tiles):
    """The cells of work ``unit``: per cell the points, the undefined ones and each class's in
    both epochs, every metric (:func:`~lidar_sig.change_map._cells.observed_metrics`) and the
    replicates' sampling part (:func:`~lidar_sig.change_map._maps.sampling_parts`) of the valid
    cells, from the coded ``tiles`` of each epoch that reach it; saved in the work folder and
    returned as a dict of arrays."""
    from ._maps import sampling_parts

    path = unit_path(uplan.work, unit)
    key = uplan.key()
    done = load_done(path, key, uplan.work)
    if done is not None:
        return {**done, "resumed": True}
    cells = uplan.cells_of(unit)
    n_classes = len(uplan.classes)
    pair = [binned_unit(unit_points(uplan, e, unit, tiles[e]), cells, n_classes) for e in (0, 1)]
    table = unit_table(pair, uplan.min_points)
    observed_metrics(table, pair, uplan.classes, render=uplan.render, frame=uplan.frame)
    null = null_metrics(table, pair, uplan.classes, render=uplan.render, frame=uplan.frame, seed=uplan.seed,
                        stream=uplan.stream, flat=cells)
    sampled = sampling_parts(null)
    out = {"cells": cells, "key": np.array(key),
           "points": np.stack([np.diff(b.starts) for b in pair]), "undefined": np.stack([b.undefined for b in pair]),
           "classes": np.stack([b.classes for b in pair]),
           "metrics": np.column_stack([table[k] for k in CHANGE_KEYS]),
           "mu0": np.column_stack([sampled[k][0] for k in CHANGE_KEYS]),
           "sigma": np.column_stack([sampled[k][1] for k in CHANGE_KEYS]),
           "defined": np.column_stack([sampled[k][2] for k in CHANGE_KEYS])}
    save_whole(path, **out)
    return out


def unit_table(pair, min_points):
    """A unit's table of what :func:`observed_metrics` and :func:`null_metrics` read and fill:
    points of each epoch, ``valid`` (both hold ``min_points`` points with defined saliency) and
    the compared values (NaN)."""
    n = len(pair[0].starts) - 1
    table = np.zeros(n, dtype=[("points_a", np.int64), ("points_b", np.int64), ("valid", bool)]
                     + [(k, np.float64) for k in CHANGE_KEYS])
    points = [np.diff(b.starts) for b in pair]
    table["points_a"], table["points_b"] = points
    table["valid"] = ((points[0] - pair[0].undefined) >= min_points) & ((points[1] - pair[1].undefined) >= min_points)
    for k in CHANGE_KEYS:
        table[k] = np.nan
    return table
