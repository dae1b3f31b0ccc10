"""What a tiled run of a set made, read back from the work folder: the tiles' statistics, what
failed and why, the set's signature (the sum of the tiles'), and each input file's per-point
saliency merged from the tiles' results chunk by chunk, or streamed into its LAS/LAZ output."""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .. import __version__
from ..progress import step
from ..saliency import Saliency
from ..signature import Signature
from .core import SetContext, Tiling
from .sources import ID_BITS
from .tasks import Plan, points_paths, result_path


@dataclass
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
    seconds: float = 0.0
    execution: str = ""

    @property
    def missing(self):
        """Lines naming what is missing and why (empty when the run is complete)."""
        lines = [f"{Path(p).name}: {why}" for p, why in self.failed_sources.items()]
        lines += [f"{name}: {why}" for name, why in self.failed_tiles.items()]
        return lines

    @property
    def complete(self):
        return not self.failed_sources and not self.failed_tiles

    def tiling_record(self):
        """The tiling as recorded in the set's archive."""
        return {"tile_size_m": self.tiling.size, "tiles": list(self.tiling.shape), "origin_m": list(self.ctx.lo),
                "centre": list(self.ctx.centre), "area_cap_m": self.ctx.area_cap,
                "n_tiles_run": len(self.tile_stats),
                "n_recomputed": sum(s["n_recomputed"] for s in self.tile_stats.values())}

    def source_records(self):
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
        has_chosen = self.plan.pipeline.strategy.name == "optimal"
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

    def saliency_of(self, source):
        """Saliency of one input file's points, in its point order (in memory); None when a
        tile holding some of them failed."""
        chunk = self.point_values(source)
        return None if chunk is None else chunk(0, source.n_points)

    def write_points(self, source, output, *, overwrite=False):
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


def sum_signatures(run):
    """The set's signature: the sum of its tiles' (count rasters are additive, SPEC 5), with the
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
