"""Resilience of a signature to sampling (docs/commands/resilience.md): every metric between a cloud and uniform
random subsamples of it, against the fraction of points kept.

The paper claims the signature barely changes down to about 60% of the points; this measures
it for any cloud, method and rendering (`lidar-sig resilience`).
"""
from __future__ import annotations

import os
from collections.abc import Iterable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from ..base.errors import LidarSigError, whole_number
from ..metrics import METRIC, METRIC_KEYS, compare
from ..base.progress import progress as _progress

if TYPE_CHECKING:
    from ..pipeline.flow import Pipeline

DEFAULT_FRACTIONS = tuple(round(f, 1) for f in np.arange(1.0, 0.05, -0.1))


@dataclass(repr=False)
class Resilience:
    """Metrics of subsamples against the full cloud.

    ``values[key]`` is a (F, R) array: fraction f of ``fractions``, repeat r; NaN where a metric
    does not apply (delta_KL and L1 of an unlabeled cloud).
    """

    source: str
    fractions: tuple[float, ...]
    points: tuple[int, ...]  # points kept per fraction
    repeats: int
    seed: int
    render: str
    method: dict[str, Any]
    values: dict[str, NDArray[np.float64]]
    area: str | None = None  # the area of interest the cloud was clipped to

    def __repr__(self) -> str:
        from ..base.views import one_line, short_name

        return one_line(f"<Resilience of {short_name(self.source)}: {len(self.fractions)} fractions "
                        f"({', '.join(f'{f:g}' for f in self.fractions[:4])}{', ...' if len(self.fractions) > 4 else ''}), "
                        f"{self.repeats} repeats, {self.render} rendering>")

    def summary(self, key: str) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64],
                                         NDArray[np.float64]]:
        """(mean, std, min, max) over the repeats, each a (F,) array, of metric ``key``."""
        v = self.values[key]
        return v.mean(axis=1), v.std(axis=1), v.min(axis=1), v.max(axis=1)

    def to_dict(self) -> dict[str, Any]:
        metrics: dict[str, dict[str, list[float]] | None] = {}
        out = {"source": self.source, "fractions": list(self.fractions), "points": list(self.points),
               "repeats": self.repeats, "seed": self.seed, "render": self.render, "method": self.method,
               "metrics": metrics, **({"aoi": self.area} if self.area else {})}
        for key in METRIC_KEYS:
            if np.isnan(self.values[key]).all():
                metrics[key] = None
                continue
            mean, std, lo, hi = self.summary(key)
            metrics[key] = {"mean": mean.tolist(), "std": std.tolist(), "min": lo.tolist(), "max": hi.tolist()}
        return out


def check_fractions(fractions: Iterable[float], what: str = "fractions") -> tuple[float, ...]:
    """``fractions`` as a tuple of floats if there is at least one, each in (0, 1] and none
    twice (it would be computed twice); else a LidarSigError naming ``what``."""
    try:
        values = tuple(float(f) for f in fractions)
    except (TypeError, ValueError):
        raise LidarSigError(f"{what} must be numbers in (0, 1], got {fractions!r}") from None
    if not values or not all(0.0 < f <= 1.0 for f in values):
        raise LidarSigError(f"{what} must be in (0, 1], got {', '.join(f'{f:g}' for f in values) or 'none'}")
    twice = sorted({f for f in values if values.count(f) > 1})
    if twice:
        raise LidarSigError(f"{what} gives {', '.join(f'{f:g}' for f in twice)} more than once; give each "
                            "fraction once")
    return values


def resilience(cloud: Any, pipeline: Pipeline | None = None, *, fractions: Iterable[float] = DEFAULT_FRACTIONS,
               repeats: int = 3, seed: int = 0, render: str = "smooth", progress: bool | None = None,
               aoi: Any = None) -> Resilience:
    """Compare ``cloud`` with ``repeats`` uniform random subsamples at each of ``fractions``.

    A subsample at fraction f keeps round(f N) points drawn without replacement (seeded by
    ``seed``, so a run can be repeated); its signature is made with the same ``pipeline``
    (default ``Pipeline()``) and compared with the full cloud's under ``render``. ``aoi``: an
    area of interest (bounds ``"XMIN,YMIN,XMAX,YMAX"`` in the cloud's CRS, or a GeoPackage or
    GeoJSON polygon file) the cloud is clipped to first.
    """
    from ..pipeline.flow import as_point_cloud, pipeline_or_default

    repeats = whole_number(repeats, "repeats", low=1)  # 2.7 ran twice, 'abc' raised a ValueError
    pipeline = pipeline_or_default(pipeline)
    area = None
    if aoi is not None:
        from ..io.clip import clip_cloud

        cloud, area = clip_cloud(cloud, aoi)
    cloud = as_point_cloud(cloud)
    fractions = check_fractions(fractions)
    seed = whole_number(seed, "the seed")
    n = len(cloud)
    points = tuple(int(round(f * n)) for f in fractions)
    need = pipeline.min_points()
    if min(points) < need:
        f = fractions[points.index(min(points))]
        raise LidarSigError(f"fraction {f:g} keeps {min(points):,} of the {n:,} points of "
                            f"{cloud.path or 'the cloud'}, fewer than the method needs ({need:,}); give larger "
                            "fractions")
    full = pipeline.run(cloud).signature
    rng = np.random.default_rng(seed)
    values = {key: np.full((len(fractions), repeats), np.nan) for key in METRIC_KEYS}
    runs = [(i, r) for i in range(len(fractions)) for r in range(repeats)]
    for i, r in _progress(runs, desc="subsamples", enabled=progress, unit="run"):
        keep = np.sort(rng.choice(n, points[i], replace=False))
        sub = cloud.subset(keep)  # labels and withheld flags with their points
        metrics = compare(full, pipeline.run(sub).signature, render=render)
        for key in METRIC_KEYS:
            if metrics[key] is not None:
                values[key][i, r] = metrics[key]
    return Resilience(str(cloud.path or "(in memory)"), fractions, points, repeats, int(seed), render,
                      pipeline.method(), values, area)


def plot_resilience(result: Resilience, path: str | os.PathLike[str], *, overwrite: bool = False) -> None:
    """A PNG of every metric against the fraction kept: the mean over the repeats, and the
    range from the smallest to the largest as a band (matplotlib's object interface: no global
    backend is set, so a notebook's own plots are untouched)."""
    from matplotlib.figure import Figure

    from ..io.atomic import atomic_output

    keys = [k for k in METRIC_KEYS if not np.isnan(result.values[k]).all()]
    fig = Figure(figsize=(13, 6), layout="constrained")
    axes = fig.subplots(2, 4)
    for ax, key in zip(axes.flat, keys):
        mean, _, lo, hi = result.summary(key)
        ax.fill_between(result.fractions, lo, hi, color="tab:blue", alpha=0.2, linewidth=0)
        ax.plot(result.fractions, mean, "o-", color="tab:blue", markersize=3)
        ax.set_title(f"{METRIC[key].name} ({METRIC[key].same:g} = same)", fontsize=10)
        ax.set_xlabel("fraction of points kept")
        ax.invert_xaxis()
        ax.grid(alpha=0.3)
    for ax in list(axes.flat)[len(keys):]:
        ax.axis("off")
    fig.suptitle(f"Resilience of the signature of {result.source} to random subsampling "
                 f"({result.repeats} repeats, {result.render} rendering)", fontsize=11)
    with atomic_output(path, overwrite=overwrite) as tmp:
        fig.savefig(tmp, format="png", dpi=110)
