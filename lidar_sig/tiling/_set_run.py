"""What a tiled run of a set made, read back from the work folder: the tiles' statistics, what
failed and why, the set's signature (the sum of the tiles'), and each input file's per-point
saliency merged from the tiles' results chunk by chunk, or streamed into its LAS/LAZ output;
and what a run of one file in tiles keeps there until asked for (:class:`KeptTiles`)."""
from __future__ import annotations

import weakref
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from .. import __version__
from ..base.errors import LidarSigError, counted
from ..base.progress import step
from ..method.saliency_map import Saliency
from ..method.signature_raster import Signature
from ._core import SetContext, Tiling
from .sources import ID_BITS
from ._tasks import Plan, points_paths, result_path, sample_path


@dataclass(repr=False)
class SetRun:
    """What a tiled run of a set made, and what it could not."""

    sources: list
    ctx: SetContext | None = None
    tiling: Tiling | None = None
    plan: Plan | None = None
    signature: Signature | None = None
    tile_stats: dict = field(default_factory=dict)
    failed_sources: dict = field(default_factory=dict)
    failed_tiles: dict = field(default_factory=dict)
    sha256: dict = field(default_factory=dict)
    excluded: dict = field(default_factory=dict)  # source id -> withheld or noise points left out
    labelled: bool = False  # some point has a class code
    records: dict = field(default_factory=dict)  # (source, part) -> its staged part's record
    reused_parts: int = 0  # staged parts a resumed run reused
    restaged: list = field(default_factory=list)  # files a resumed run staged again, each with why: "a.laz (edited since)"
    seconds: float = 0.0
    execution: str = ""
    density: float | None = None  # points per m², when a run's ``sample`` measured it
    sampled: float | None = None  # and the sample's points per m²

    def __getstate__(self):
        # what a task of the run needs travels to a worker; the set's signature (tens of MiB:
        # the counts of every class) stays in this process
        return {**self.__dict__, "signature": None}

    def __repr__(self):
        state = "complete" if self.complete else f"incomplete: {len(self.missing)} missing"
        return (f"<SetRun {counted(len(self.sources), 'file')}, {counted(len(self.tile_stats), 'tile')}, {state}, "
                f"{self.execution or 'not run'}>")

    @property
    def missing(self):
        """Lines naming what is missing and why (empty when the run is complete)."""
        lines = [f"{Path(p).name}: {why}" for p, why in self.failed_sources.items()]
        lines += [f"{name}: {why}" for name, why in self.failed_tiles.items()]
        return lines

    @property
    def complete(self):
        return not self.failed_sources and not self.failed_tiles

    def tiling_record(self) -> dict[str, Any]:
        """The tiling as recorded in the set's archive."""
        return {"tile_size_m": self.tiling.size, "tiles": list(self.tiling.shape), "origin_m": list(self.ctx.lo),
                "centre": list(self.ctx.centre), "area_cap_m": self.ctx.area_cap,
                "n_tiles_run": len(self.tile_stats),
                "n_recomputed": sum(s["n_recomputed"] for s in self.tile_stats.values())}

    def summary(self, over: int | None = None, memory: int | None = None) -> list[str]:
        """Two lines for people: the tiles (for one file run in tiles because its ``over``
        points exceed the ``memory`` budget as one block, why), and where and how fast they
        ran. None before the tiles were made (every input failed)."""
        from .memory import exceed

        if self.tiling is None:
            return []
        n = sum(s["n_points"] for s in self.tile_stats.values())
        recomputed = sum(s["n_recomputed"] for s in self.tile_stats.values())
        resumed = sum(bool(s.get("resumed")) for s in self.tile_stats.values())
        nx, ny = self.tiling.shape
        lost = f" ({len(self.failed_sources)} missing)" if self.failed_sources else ""
        excluded = sum(self.excluded.values())
        head = (f"{exceed(over, memory)}: processed in {counted(len(self.tile_stats), 'tile')}" if over else
                f"set of {counted(len(self.sources), 'file')}{lost}: {counted(n, 'point')} in "
                f"{counted(len(self.tile_stats), 'tile')}")
        return [f"{head} of {self.tiling.size:.4g} m ({nx} x {ny} grid"
                + (f", {resumed} reused" if resumed else "") + f"), {counted(recomputed, 'point')} recomputed "
                "with a wider halo" + (f"; {counted(excluded, 'withheld or noise point')} left out" if excluded else ""),
                f"{self.execution}: {self.seconds:.1f} s, {n / max(self.seconds, 1e-9):,.0f} points/s"]

    def source_records(self) -> list[dict[str, str]]:
        """Every source file with its SHA-256 (those that could be read)."""
        return [{"path": s.path, "sha256": self.sha256[s.path]} for s in self.sources if s.path in self.sha256]

    def point_values(self, source):
        """``(start, stop) -> Saliency`` of points [start, stop) of ``source``, in its point
        order, merged from the tiles' results (each sorted by point identifier: a slice of each
        tile per chunk, so that memory stays one chunk's whatever the file's order); None when
        a tile holding some of its points failed. Points left out of the run (withheld and
        noise) are undefined."""
        key = str(source.id)
        tiles = [ij for ij, stats in self.tile_stats.items() if key in stats["sources"]]
        found = self.excluded.get(source.id, 0) + sum(self.tile_stats[ij]["sources"][key] for ij in tiles)
        if found != source.n_points:
            return None
        has_chosen = self.plan.pipeline.strategy.chooses_scale
        base = np.int64(source.id) << np.int64(ID_BITS)

        def chunk(start, stop):
            values = np.full((stop - start, 3), np.nan)
            chosen = np.full(stop - start, -1, np.int64)
            for ij in tiles:
                ids_path, values_path = points_paths(self.plan.work, ij)
                ids = np.load(ids_path, mmap_mode="r")  # mapped: a binary search reads a few pages
                a, b = np.searchsorted(ids, [base + start, base + stop])
                if a < b:
                    at = np.asarray(ids[a:b]) - (base + start)
                    rec = np.asarray(np.load(values_path, mmap_mode="r")[a:b])
                    values[at] = rec["values"]
                    chosen[at] = rec["chosen"]
                del ids  # unmapped: the pages read leave the process
            return Saliency.from_values(values, chosen if has_chosen else None)
        return chunk

    def box_points(self, ij: tuple[int, int]) -> Any:
        """The staged points (structured records: x, y, z in the files' units, label, id) within
        tile ``ij``'s box and a margin of a hundredth of its side: its core points and some of
        its neighbours' (every staged point lies in some tile's box)."""
        from .sources import load_cells

        plan = self.plan
        x0, y0, x1, y1 = plan.tiling.box(*ij)
        m = 0.01 * plan.tiling.size  # the core is decided by the index, not the box's round-off
        return load_cells(plan.files, plan.cells, plan._raw((x0 - m, y0 - m, x1 + m, y1 + m)))

    def sample_points(self, ij: tuple[int, int]) -> Any:
        """Tile ``ij``'s core points of the run's sample (``plan.sample``; a change map's work
        units code them), as its tile kept them (records of
        :data:`~lidar_sig.tiling._tasks.SAMPLE_POINTS`: raw coordinates in the files' units,
        class code, key, (Cl, Cs, Cp))."""
        return np.load(sample_path(self.plan.work, ij))

    def saliency_of(self, source: Any) -> Saliency | None:
        """Saliency of one input file's points, in its point order (in memory); None when a
        tile holding some of them failed."""
        chunk = self.point_values(source)
        return None if chunk is None else chunk(0, source.n_points)

    def write_points(self, source: Any, output: str | Path, *, overwrite: bool = False) -> bool:
        """Write ``source`` with its per-point saliency to the LAS/LAZ ``output``, streamed in
        chunks; False (nothing written) when a tile holding some of its points failed."""
        from ..io.las import write_las_chunks

        chunk = self.point_values(source)
        if chunk is None:
            return False
        pipe = self.plan.pipeline
        with step(f"writing {Path(output).name}", points=source.n_points):
            write_las_chunks(output, source.path, chunk, scale_kind=pipe.scales.kind, scale_values=pipe.scales.values,
                             overwrite=overwrite)
        return True


class KeptTiles:
    """What a run of one LAS/LAZ file in tiles keeps in its work folder until asked for: the
    per-point values, in tiles (:meth:`saliency` gathers them, :meth:`write_points` streams them
    into a LAS/LAZ file chunk by chunk), and the file's signature, the sum of its tiles'. The work
    folder is removed by :meth:`close`, or when this is collected.
    :class:`lidar_sig.pipeline.result.TiledResult` is the Result made of it."""

    def __init__(self, run: SetRun, work: str | Path, over: int | None, memory: int,
                 remove: Callable[[Path], Any]) -> None:
        self.run = run
        self.source = run.sources[0]
        self.over = over
        self.memory = memory
        self.work = Path(work)
        self.metadata = {**run.signature.metadata, "source": self.source.path, "tiling": run.tiling_record()}
        self._closed = weakref.finalize(self, remove, self.work)

    @property
    def signature(self) -> Signature:
        """The file's Signature: the sum of its tiles' (count rasters are additive)."""
        return self.run.signature

    def saliency(self) -> Saliency:
        """Per-point Saliency of the whole file, in its point order, gathered into memory."""
        self.check_open()
        return self.run.saliency_of(self.source)

    def summary_lines(self) -> list[str]:
        """What the tiles were (:meth:`SetRun.summary`)."""
        return self.run.summary(self.over, self.memory)

    def write_points(self, path: str | Path, *, overwrite: bool = False) -> None:
        """Stream the per-point values into the LAS/LAZ file ``path``."""
        self.check_open()
        self.run.write_points(self.source, path, overwrite=overwrite)

    def close(self) -> None:
        """Remove the work folder that holds the per-point values (the signature stays)."""
        self._closed()

    def check_open(self) -> None:
        """Refuse to read values a closed run no longer holds."""
        if not self._closed.alive:
            raise LidarSigError("this result in tiles was closed: its per-point values are gone; run it again")


#: The name lidar_sig/tiling/run_set.py still builds KeptTiles by (its author renames it there).
TiledResult = KeptTiles


def sum_signatures(run):
    """The set's signature: the sum of its tiles' (count rasters are additive, docs/method.md, "Signatures"), with the
    set's metadata."""
    plan = run.plan
    counts = None
    egeom = totals = None
    n_undefined = 0
    for ij in run.tile_stats:
        with np.load(result_path(plan.work, ij)) as r:
            if counts is None:
                shape = (len(plan.classes), plan.pipeline.frame.size, plan.pipeline.frame.size)
                counts = np.zeros(int(np.prod(shape)), np.int64)
                egeom, totals = np.zeros_like(r["egeom_counts"]), np.zeros_like(r["class_totals"])
            counts[r["counts_at"]] += r["counts"]
            egeom += r["egeom_counts"]
            totals += r["class_totals"]
        n_undefined += run.tile_stats[ij]["n_undefined"]
    stats = {k: sum(s[k] for s in run.tile_stats.values()) for k in ("n_points", "n_locations", "n_capped")}
    n_excluded = sum(run.excluded.values())
    pipe = plan.pipeline
    metadata = {"lidar_sig_version": __version__, "source": ", ".join(s.name for s in run.sources),
                "scales": pipe.scales.describe(), "crs": next((s.crs for s in run.sources if s.crs), None),
                "n_points": stats["n_points"] + n_excluded, "n_undefined": n_undefined, "n_capped": stats["n_capped"],
                "n_duplicates": stats["n_points"] - stats["n_locations"], "n_excluded": n_excluded,
                "resolved_scales": list(run.ctx.scales), "units": next(s.units for s in run.sources if s.error is None),
                "metres_per_unit": list(run.ctx.factors), **pipe.method()}
    return Signature(counts.reshape(shape), pipe.frame, plan.classes, egeom, n_undefined, metadata, totals)
