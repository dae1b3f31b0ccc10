"""The tasks of a tiled run, each small enough to send to a worker: staging one part of a file,
the second-neighbour distances of one tile or of its part of a sample (for the area-weight cap),
and one tile's saliency and
signature written to the work folder (each file complete or absent, so that a resumed run skips
finished tiles); and the :class:`Plan` every tile task shares."""
from __future__ import annotations

import json
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..method.signature_raster import Signature
from ..numerics.records import pick
from ..numerics.sorting import stable_order
from ._core import SetContext, Tiling, tile_cap_sample, tile_name, tile_saliency, tile_second_distances
from .sources import Cells, load_cells, source_of, stage_part
from .work import FINISHED, load_done, save_whole


#: Per-point results: (Cl, Cs, Cp) and the chosen scale index (-1: none or undefined).
POINT_VALUES = np.dtype([("values", "f8", 3), ("chosen", "i8")])
#: A tile's points of a sample (a change map's), as the cells take them: raw coordinates (the
#: files' units), class code, the sample's key of the point and (Cl, Cs, Cp); written by the
#: tile, which has them at hand, so that coding them for the cells reads no staged point again.
SAMPLE_POINTS = np.dtype([("x", "f8"), ("y", "f8"), ("z", "f8"), ("label", "i2"), ("key", "u8"),
                          ("values", "f8", 3)])


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
    #: The points whose saliency is asked for, a sample (``sample.keys(raw xyz, class codes)``
    #: -> (N,) keys, ``sample.mask(raw xyz, class codes, keys)`` -> (N,) bool; a change map's,
    #: :class:`lidar_sig.change_map.Sample`), whose points the tiles keep (:data:`SAMPLE_POINTS`);
    #: None: every point, none kept.
    sample: object = None
    #: True when the cap's pass kept every core point's second-neighbour distance
    #: (:func:`second_task`), which the tiles then take; False when the cap came from a sample
    #: (:func:`cap_task`) and each tile searches its own.
    second_known: bool = True

    def key(self):
        """Changes whenever a tile's result would: the set's files as staged (path, size, time,
        points), its context, the method, the points left out, the tiling and the sample."""
        return json.dumps([self.staged, self.ctx.key(), self.pipeline.method(), self.classes.name,
                           self.pipeline.noise_codes(), self.pipeline.frame.size, self.tiling.size,
                           repr(self.sample), None if self.sample is None else SAMPLE_POINTS.descr],
                          default=str)  # a tile of a sample keeps its points: a folder without them is another

    def _raw(self, bounds):
        """Plan-view ``bounds`` (x0, y0, x1, y1 in centred metres) in the files' coordinates."""
        x0, y0, x1, y1 = bounds
        c, f = self.ctx.centre, self.ctx.factors
        return (x0 / f[0] + c[0], y0 / f[1] + c[1], x1 / f[0] + c[0], y1 / f[1] + c[1])

    def load(self, bounds, *, raw=False):
        """(xyz centred metres, ids, labels) of the staged points within plan-view ``bounds``,
        and with ``raw`` their coordinates in the files' units last."""
        from ._load import count_within, metres_within  # numba: loaded by the tasks that load, not on import

        rec = load_cells(self.files, self.cells, self._raw(bounds))
        frame = (np.asarray(self.ctx.centre, dtype=np.float64), np.asarray(self.ctx.factors, dtype=np.float64),
                 *(float(b) for b in bounds))
        m = count_within(rec["x"], rec["y"], *frame)  # the outputs' size: the staged box holds more
        xyz, coords = np.empty((m, 3)), np.empty((m, 3))
        ids, labels = np.empty(m, rec.dtype["id"]), np.empty(m, rec.dtype["label"])
        metres_within(rec["x"], rec["y"], rec["z"], rec["id"], rec["label"], *frame, xyz, coords, ids, labels)
        return (xyz, ids, labels, coords) if raw else (xyz, ids, labels)

    def load_points(self, bounds):
        xyz, ids, _ = self.load(bounds)
        return xyz, ids

    def second_of(self, xyz, ids):
        """(N,) second-neighbour distance in the whole set of the staged points ``xyz`` (centred
        metres), ``ids``: from the files of the tiles whose core holds them (:func:`second_task`)."""
        d = np.empty(len(ids))
        tile = self.tiling.index(xyz)
        ny = self.tiling.shape[1]
        key = tile[:, 0] * ny + tile[:, 1]
        for k in np.flatnonzero(np.bincount(key)):  # each tile holding some of the points
            ij = (int(k) // ny, int(k) % ny)
            _, ids_path, d_path = second_paths(self.work, ij)
            known = np.load(ids_path, mmap_mode="r")
            mine = np.flatnonzero(key == k)
            at = np.searchsorted(known, ids[mine])  # the file is sorted; the points need not be
            if at.max(initial=0) >= len(known) or not np.array_equal(known[at], ids[mine]):
                raise RuntimeError(f"{tile_name(*ij)}: points without a second-neighbour distance")
            d[mine] = np.load(d_path, mmap_mode="r")[at]
            del known  # unmapped: the pages read leave the process
        return d

    def occupied(self, ij):
        """True when tile ``ij``'s box meets a staged cell: a tile that meets none has no core
        points."""
        return any(key in self.files for key in self.cells.covering(self._raw(self.tiling.box(*ij))))


def result_path(work, ij):
    """The file of tile ``ij``'s result in the work folder (its statistics and signature; it is
    written last, so that its presence means the tile's per-point files are whole)."""
    return Path(work) / FINISHED / f"{tile_name(*ij)}.npz"


def points_paths(work, ij):
    """The files of tile ``ij``'s per-point results: the point identifiers, ascending, and
    their (Cl, Cs, Cp) and chosen scale index (records of POINT_VALUES), in the same order."""
    folder = Path(work) / FINISHED
    return folder / f"{tile_name(*ij)}.ids.npy", folder / f"{tile_name(*ij)}.values.npy"


def sample_path(work, ij):
    """The file of tile ``ij``'s points of the run's sample (records of :data:`SAMPLE_POINTS`)."""
    return Path(work) / FINISHED / f"{tile_name(*ij)}.sample.npy"


def second_paths(work, ij):
    """The files of tile ``ij``'s second-neighbour distances: one per distinct location of its
    core points, ascending (for the set's median); its core points' identifiers, ascending; and
    their distances in the same order (for the tiles' weights)."""
    folder = Path(work) / "second"
    name = tile_name(*ij)
    return folder / f"{name}.npy", folder / f"{name}.ids.npy", folder / f"{name}.d.npy"


def stage_task(work, source, part, start, stop, cells, noise_codes):
    """Stage one part of one file (a task), leaving out withheld and noise points
    (``noise_codes``, None for none)."""
    return stage_part(work, source, part, start, stop, cells, noise_codes)


def _sample_points(first, core, values):
    """The :data:`SAMPLE_POINTS` of a tile's core points in its sample, ordered by key: whatever
    the files' order, cut or listing, so that what is drawn from them in order (the report's
    top view) is too (``first``: the first block's raw coordinates, class codes, keys and
    sample; ``core``: its core points; ``values``: the sample's saliency, in that block's order)."""
    at = np.flatnonzero(core)[first["sampled"][core]] if "sampled" in first else np.empty(0, np.int64)
    out = np.empty(len(at), SAMPLE_POINTS)
    if len(at):
        raw = first["raw"][at]
        out["x"], out["y"], out["z"] = raw[:, 0], raw[:, 1], raw[:, 2]
        out["label"], out["key"] = first["labels"][at], first["keys"][at]
    out["values"] = values
    return pick(out, stable_order(out["key"]))


def second_task(plan, ij):
    """Second-neighbour distances of one tile's core points (a task), kept in the work folder
    (:func:`second_paths`): for the set's median (:func:`lidar_sig.tiling._median.sorted_median`)
    and for the tiles, which take them instead of searching again (:meth:`Plan.second_of`);
    returns how many locations."""
    ids, point_d, location_d = tile_second_distances(plan.load_points, plan.tiling, ij, plan.ctx)
    order = np.argsort(ids, kind="stable")
    locations_path, ids_path, d_path = second_paths(plan.work, ij)
    save_whole(ids_path, ids[order])
    save_whole(d_path, point_d[order])
    save_whole(locations_path, np.sort(location_d))
    return len(location_d)


def cap_task(plan, ij, share):
    """Second-neighbour distances of the distinct locations of one tile's core points in the
    area-weight cap's sample of ``share`` (a task; :func:`tile_cap_sample`)."""
    return tile_cap_sample(lambda bounds: plan.load(bounds, raw=True), plan.tiling, ij, plan.ctx, share)


def tile_task(plan, ij):
    """Saliency and signature of one tile's core points, written to the work folder (a task);
    returns the tile's statistics. A result of the same set and method is reused."""
    path = result_path(plan.work, ij)
    sample_file = (sample_path(plan.work, ij),) if plan.sample is not None else ()
    done = load_done(path, plan.key(), plan.work, extra=points_paths(plan.work, ij) + sample_file)
    if done is not None:
        return {**json.loads(str(done["stats"])), "resumed": True}
    key = plan.key()  # another run's result, or a damaged one, is gone: its per-point files are replaced
    t0 = time.perf_counter()
    first = {}

    def load(bounds):  # the tile's own block keeps its class codes: no second read for them
        xyz, ids, labels, raw = plan.load(bounds, raw=True)
        if not first:
            first.update(xyz=xyz, labels=labels, raw=raw)
        return xyz, ids

    second_of = plan.second_of if plan.ctx.area_cap is not None and plan.second_known else None  # the cap pass's

    def sampled():  # the sample's keys, kept for its points' file
        if "sampled" not in first:
            first["keys"] = plan.sample.keys(first["raw"], first["labels"])
            first["sampled"] = plan.sample.mask(first["raw"], first["labels"], first["keys"])
        return first["sampled"]

    r = tile_saliency(plan.pipeline, load, plan.tiling, ij, plan.ctx, second_of=second_of,
                      sampled=None if plan.sample is None else sampled)
    codes, core = np.empty(0, np.int64), np.zeros(0, bool)
    if first:  # core points in the order of the first block, as tile_saliency lists them
        core = plan.tiling.core(first["xyz"][:, 0], first["xyz"][:, 1], ij)
        codes = first["labels"][core]
    sig = Signature.from_saliency(r.values, plan.classes.index(codes), classes=plan.classes,
                                  frame=plan.pipeline.frame)
    flat = sig.counts.ravel()
    nz = np.flatnonzero(flat)
    per_source = np.bincount(source_of(r.ids))
    stats = {**r.stats, "n_undefined": sig.n_undefined, "seconds": time.perf_counter() - t0,
             "sources": {str(s): int(c) for s, c in enumerate(per_source) if c}, "resumed": False}
    # by identifier: each file's points in its order; of a sample, its points alone (the others
    # are undefined: the files hold what was computed)
    kept = first["sampled"][core] if "sampled" in first else slice(None)
    ids, values, chosen = r.ids[kept], r.values[kept], None if r.chosen is None else r.chosen[kept]
    order = np.argsort(ids, kind="stable")
    rec = np.empty(len(order), POINT_VALUES)
    rec["values"] = values[order]
    rec["chosen"] = chosen[order] if chosen is not None else -1
    ids_path, values_path = points_paths(plan.work, ij)
    save_whole(ids_path, ids[order])
    save_whole(values_path, rec)
    if plan.sample is not None:
        save_whole(sample_path(plan.work, ij), _sample_points(first, core, values))
    save_whole(path, counts_at=nz, counts=flat[nz], egeom_counts=sig.egeom_counts, class_totals=sig.class_totals,
               has_chosen=np.array(r.chosen is not None), key=np.array(key),
               stats=np.array(json.dumps(stats)))  # last: a tile's result exists whole or not at all
    return stats
