"""The tasks of a tiled run, each small enough to send to a worker: staging one part of a file,
the second-neighbour distances of one tile (for the area-weight cap), and one tile's saliency and
signature written to the work folder (each file complete or absent, so that a resumed run skips
finished tiles); and the :class:`Plan` every tile task shares."""
from __future__ import annotations

import json
import os
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..signature import Signature
from .core import SetContext, Tiling, positions_of, tile_name, tile_saliency, tile_second_distances
from .sources import Cells, load_cells, source_of, stage_part


@dataclass(frozen=True)
class Plan:
    """Everything a tile task needs (small: pickled to each worker)."""

    work: str
    pipeline: object
    ctx: SetContext
    tiling: Tiling
    cells: Cells
    files: dict
    classes: object
    staged: str = ""

    def key(self):
        """Changes whenever a tile's result would: the set's files as staged (path, size, time,
        points), its context, the method, the points left out and the tiling."""
        return json.dumps([self.staged, self.ctx.key(), self.pipeline.method(), self.classes.name,
                           self.pipeline.noise_codes(), self.pipeline.frame.size, self.tiling.size], default=str)

    def _raw(self, bounds):
        """Plan-view ``bounds`` (x0, y0, x1, y1 in centred metres) in the files' coordinates."""
        x0, y0, x1, y1 = bounds
        c, f = self.ctx.centre, self.ctx.factors
        return (x0 / f[0] + c[0], y0 / f[1] + c[1], x1 / f[0] + c[0], y1 / f[1] + c[1])

    def load(self, bounds):
        """(xyz centred metres, ids, labels) of the staged points within plan-view ``bounds``."""
        x0, y0, x1, y1 = bounds
        rec = load_cells(self.files, self.cells, self._raw(bounds))
        xyz = self.ctx.metric(np.column_stack([rec["x"], rec["y"], rec["z"]]))
        inside = (xyz[:, 0] >= x0) & (xyz[:, 0] <= x1) & (xyz[:, 1] >= y0) & (xyz[:, 1] <= y1)
        return xyz[inside], rec["id"][inside], rec["label"][inside]

    def load_points(self, bounds):
        xyz, ids, _ = self.load(bounds)
        return xyz, ids

    def occupied(self, ij):
        """True when tile ``ij``'s box meets a staged cell: a tile that meets none has no core
        points."""
        return any(key in self.files for key in self.cells.covering(self._raw(self.tiling.box(*ij))))


def result_path(work, ij):
    """The file of tile ``ij``'s result in the work folder."""
    return Path(work) / "tiles" / f"{tile_name(*ij)}.npz"


def stage_task(work, source, part, start, stop, cells, noise_codes):
    """Stage one part of one file (a task), leaving out withheld and noise points
    (``noise_codes``, None for none)."""
    return stage_part(work, source, part, start, stop, cells, noise_codes)


def second_task(plan, ij):
    """Second-neighbour distances of one tile's core locations (a task)."""
    return tile_second_distances(plan.load_points, plan.tiling, ij, plan.ctx)


def tile_task(plan, ij):
    """Saliency and signature of one tile's core points, written to the work folder (a task);
    returns the tile's statistics. A result of the same set and method is reused."""
    path = result_path(plan.work, ij)
    key = plan.key()
    if path.is_file():
        with np.load(path) as done:
            if str(done["key"]) == key:
                return {**json.loads(str(done["stats"])), "resumed": True}
    t0 = time.perf_counter()
    r = tile_saliency(plan.pipeline, plan.load_points, plan.tiling, ij, plan.ctx)
    # the core points' class codes, from the tile's box widened by round-off (core points are
    # decided by a floor of the same coordinates, which can put a point an ulp outside the box)
    x0, y0, x1, y1 = plan.tiling.box(*ij)
    eps = 1e-6 * max(plan.tiling.size, 1.0)
    _, ids, labels = plan.load((x0 - eps, y0 - eps, x1 + eps, y1 + eps))
    mine = np.isin(ids, r.ids)
    if int(mine.sum()) != len(r.ids):
        raise RuntimeError(f"{tile_name(*ij)}: {len(r.ids) - int(mine.sum())} core points not found again "
                           "for their class codes")
    codes = np.empty(len(r.ids), np.int64)
    codes[positions_of(r.ids, ids[mine])] = labels[mine]
    sig = Signature.from_saliency(r.values, plan.classes.index(codes), classes=plan.classes,
                                  frame=plan.pipeline.frame)
    flat = sig.counts.ravel()
    nz = np.flatnonzero(flat)
    stats = {**r.stats, "n_undefined": sig.n_undefined, "seconds": time.perf_counter() - t0,
             "sources": sorted(int(s) for s in np.unique(source_of(r.ids))), "resumed": False}
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.stem}.{os.getpid()}.tmp.npz")
    np.savez(tmp, ids=r.ids, values=r.values,
             chosen=r.chosen if r.chosen is not None else np.empty(0, np.int64),
             counts_at=nz, counts=flat[nz], egeom_counts=sig.egeom_counts, class_totals=sig.class_totals,
             key=np.array(key), stats=np.array(json.dumps(stats)))
    os.replace(tmp, path)  # a tile's result exists whole or not at all
    return stats
