"""What a file holds (``lidar-sig info``; docs/commands/info.md): a signature archive, a survey
catalogue or a point cloud, described in lines for people and in facts for a program."""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

from ..base.errors import arg, as_path, counted
from ._common import Columns, JobRun, PathLike

if TYPE_CHECKING:
    from pathlib import Path

    from ..method.cloud import PointCloud


@dataclass(repr=False)
class Description(JobRun):
    """What :func:`info` found: ``kind`` ("archive", "catalogue" or "cloud"), ``lines`` for
    people, ``facts`` as plain values for JSON."""

    kind: str = ""
    facts: dict[str, Any] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        return {"kind": self.kind, **self.facts}

    def __repr__(self) -> str:
        from ..base.views import one_line

        return one_line(f"<Description of a {self.kind}: {self.lines[0] if self.lines else ''}>")


def info(path: PathLike, *, columns: Columns = None) -> Description:
    """Describe the file ``path``: an archive's method, signature and sources; a catalogue's
    method, CRSs and tiles; a cloud's points, bounds, LAS record, withheld points and labels
    (``columns`` of a text file)."""
    from ..io import HDF5_EXTENSIONS, read

    path = as_path(path, "info")
    if path.suffix.lower() in HDF5_EXTENSIONS:
        from ..io.catalog_file import is_catalog

        if is_catalog(path):
            from ..survey_catalog import Catalog

            cat = Catalog(path)
            facts = {"path": str(path), "tiles": [{"name": str(n), "points": int(p)}
                                                  for n, p in zip(cat.columns["name"], cat.columns["n_points"])],
                     "method": cat.method, "classes": cat.classes.name, "frame": cat.frame.size}
            return Description(kind="catalogue", lines=cat.summary(), facts=facts)
        from ..io import archive_summary, load_signature

        sig = load_signature(path)
        facts = {"path": str(path), "signature": sig.summary(),
                 "method": {k: sig.metadata[k] for k in ("descriptor", "strategy", "scale_kind", "scale_values",
                                                         "scale_units", "weights") if k in sig.metadata}}
        return Description(kind="archive", lines=archive_summary(path), facts=facts)
    return _cloud(path, read(path, columns=columns))


def _cloud(path: Path, cloud: PointCloud) -> Description:
    import numpy as np

    from ..numerics.bounds import bounds

    lo, hi = bounds(cloud.xyz)
    facts: dict[str, Any] = {"path": str(path), "points": len(cloud), "bounds": {"min": lo.tolist(), "max": hi.tolist()},
                             "crs": cloud.crs}
    lines = [f"{path}: {counted(len(cloud), 'point')}",
             "  bounds " + ", ".join(f"{a} {low:.2f} .. {high:.2f}" for a, low, high in zip("xyz", lo, hi))]
    las = cloud.source
    if las is not None and hasattr(las, "header"):
        h = las.header
        dims = list(h.point_format.dimension_names)
        crs = [type(v).__name__ for v in h.vlrs if "Coordinate" in type(v).__name__ or "GeoKey" in type(v).__name__]
        facts["las"] = {"version": str(h.version), "point_format": int(h.point_format.id), "dimensions": dims,
                        "crs_records": crs}
        lines.append(f"  LAS {h.version}, point format {h.point_format.id}, dimensions {', '.join(dims)}")
        lines.append(f"  CRS record: {', '.join(crs) if crs else 'none'}")
    if cloud.withheld is not None:
        facts["withheld"] = int(cloud.withheld.sum())
        lines.append(f"  withheld: {counted(facts['withheld'], 'point')} (left out of runs unless "
                     f"{arg('keep_noise', True)})")
    if cloud.labels is None:
        facts["labels"] = None
        lines.append("  labels: none")
    else:
        codes, counts = np.unique(cloud.labels, return_counts=True)
        facts["labels"] = {str(int(c)): int(n) for c, n in zip(codes, counts)}
        lines.append("  labels: " + ", ".join(f"{c}: {n:,}" for c, n in zip(codes, counts)))
    return Description(kind="cloud", lines=lines, facts=facts)
