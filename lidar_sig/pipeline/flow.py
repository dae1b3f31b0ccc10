"""Pipeline: cloud -> neighbourhoods -> descriptor -> strategy -> Saliency and Signature."""
from __future__ import annotations

import os
import time
import warnings
from collections.abc import Sequence
from functools import partial
from typing import TYPE_CHECKING, Any

import numpy as np

from .. import __version__
from ..method.classes import UNLABELED, class_table
from ..method.cloud import PointCloud, kept_points
from ..base.compile import COMMON, announce_compilation, load_kernels, warm_up
from ..base.errors import FACE, LidarSigError, LidarSigWarning, a_kind, arg, counted
from ..io.open3d import from_open3d, is_open3d
from ..numerics.bounds import nan_rows
from ..numerics.neighbors import (WEIGHTS, NeighborIndex, Weights, cap_share, in_cap_windows, set_area_cap,
                                  unique_points)
from ..plugins import get_descriptor, get_strategy
from ..base.progress import step
from .result import Result, TiledResult
from ..method.saliency_map import Saliency
from ..method.scales import Scales, recorded_scales
from ..method.signature_raster import Frame, Signature

if TYPE_CHECKING:
    from ..method.classes import ClassTable
    from ..plugins import Descriptor, Strategy
    from ..tiling.execution import Execution


#: Share of neighbourhoods cut at max_neighbors above which a run warns.
CAPPED_WARNING = 0.5


class Pipeline:
    """The paper's method with one descriptor and one scale strategy.

    Parameters
    ----------
    descriptor : str or Descriptor
        Registered name (``lidar-sig plugins`` lists them: c3dcm, t3dvt, t3dvt-get) or an
        instance (e.g. ``T3DVT(diffusion=False)``); default ``"c3dcm"``.
    strategy : str or Strategy
        ``"multiscale"`` (default) or ``"optimal"``.
    scales : Scales, optional
        Defaults to the strategy's default: Multiscale k = 20, 30, 40 nearest neighbours;
        Optimal-scale k = 10, 20, ..., 100 (the paper's). The paper's Multiscale setting is
        ``radii(0.009, 0.010, 0.011, units="normalized")``.
    weights : {"area", "none"}
        How neighbours count in a neighbourhood's tensor: by the area each stands for (default;
        robust to the scan pattern and to thinning, see :mod:`lidar_sig.numerics.neighbors`) or equally
        (the paper's plain means).
    max_neighbors : int
        Cap of a spherical neighbourhood, nearest first (docs/method.md, "Neighbourhoods and scales"); default 512.
    min_neighbors : int
        Fewest neighbours (x_i included) for a defined saliency at a scale; default 3.
    classes : str or ClassTable
        Semantic class table for the augmented signature; default ``"asprs"``.
    frame : Frame
        Signature image frame; default 512 x 512 px.
    progress : bool or None
        Show a progress bar; None shows it on a terminal only.
    keep_noise : bool
        False (default) leaves out the points flagged withheld (LAS) and those of the class
        table's noise classes (ASPRS 7 low point and 18 high noise in ``asprs`` and ``paper``;
        none in ``isprs-vaihingen``), as PDAL and lidR users drop them first: they join no
        neighbourhood, signature or class total, and get an undefined saliency in per-point
        outputs (every point stays in the output file). Their number is reported
        (``n_excluded``). True uses every point.

    Exact duplicate points (same x, y, z) are one location: the neighbour search sees each
    location once, so copies neither vote nor fill a neighbourhood, and every copy gets the
    location's saliency. Their number is reported (``n_duplicates``).

    Examples
    --------
    >>> import lidar_sig as ls
    >>> ls.Pipeline().scales.describe()
    'k 20, 30, 40'
    >>> ls.Pipeline(strategy="optimal").scales.describe()
    'k 10, 20, 30, 40, 50, 60, 70, 80, 90, 100'
    """

    def __init__(self, descriptor: str | Descriptor = "c3dcm", strategy: str | Strategy = "multiscale",
                 scales: Scales | None = None, *, weights: str = "area", max_neighbors: int = 512,
                 min_neighbors: int = 3, classes: str | ClassTable = "asprs", frame: Frame | None = None,
                 progress: bool | None = None, keep_noise: bool = False) -> None:
        self.descriptor = get_descriptor(descriptor)
        self.strategy = get_strategy(strategy)
        self.scales = scales if scales is not None else self.strategy.default_scales
        if not isinstance(self.scales, Scales):
            raise LidarSigError("scales must be made with lidar_sig.radii(...) or lidar_sig.knn(...)")
        if not isinstance(weights, str) or weights not in WEIGHTS:
            raise LidarSigError(f"weights must be one of {', '.join(WEIGHTS)}, got {weights!r}")
        whole = all(isinstance(v, (int, np.integer)) and not isinstance(v, bool) for v in (max_neighbors, min_neighbors))
        if not whole or not 3 <= max_neighbors <= 100_000 or not 2 <= min_neighbors <= max_neighbors:
            raise LidarSigError(f"max_neighbors must be a whole number from 3 to 100,000 and min_neighbors one "
                                f"from 2 to max_neighbors, got {max_neighbors!r} and {min_neighbors!r}")
        if self.scales.by_count and min(self.scales.values) < min_neighbors:  # no point is ever defined there
            raise LidarSigError(f"k = {min(self.scales.values)} is below min_neighbors ({min_neighbors}), the fewest "
                                f"points a saliency needs: no point would have one at that scale; use k of at least "
                                f"{min_neighbors} ({arg('k') if FACE.get() == 'cli' else 'scales=knn(...)'})")
        if frame is not None and not isinstance(frame, Frame):
            raise LidarSigError(f"frame must be a lidar_sig.Frame, got {frame!r}")
        if not isinstance(keep_noise, (bool, np.bool_)):
            raise LidarSigError(f"keep_noise must be True or False, got {keep_noise!r}")
        self.keep_noise = bool(keep_noise)
        self.weights = Weights(weights)
        self.max_neighbors = int(max_neighbors)
        self.min_neighbors = int(min_neighbors)
        self.classes = class_table(classes)
        self.frame = frame or Frame()
        self.progress = progress

    def __repr__(self) -> str:
        noise = ", keeps noise" if self.keep_noise else ""
        return (f"<Pipeline {self.descriptor.name} {self.strategy.name}, {self.scales.describe()}, {self.weights} "
                f"weights, classes {self.classes.name}{noise}>")

    @classmethod
    def from_method(cls, method: dict[str, Any], **kwargs: Any) -> Pipeline:
        """The pipeline that made a signature, from its recorded method (:meth:`method`, as
        archives keep it); ``kwargs`` as for the constructor (classes, frame, progress)."""
        try:
            scales = recorded_scales(method)
            if scales is None:
                raise KeyError("scale_kind")
            descriptor = get_descriptor(method["descriptor"], **method.get("descriptor_params", {}))
            extra = {k: int(method[k]) for k in ("max_neighbors", "min_neighbors") if k in method}
            return cls(descriptor, method["strategy"], scales, weights=method.get("weights", "none"),
                       keep_noise=bool(method.get("keep_noise", False)), **extra, **kwargs)
        except (KeyError, TypeError) as exc:
            raise LidarSigError(f"the recorded method is incomplete or damaged ({exc}); make the "
                                "signature again") from None

    def method(self) -> dict[str, Any]:
        """What makes two signatures comparable (besides frame and class table): descriptor and
        its parameters, strategy, scales, neighbour weights, neighbourhood limits and whether
        withheld and noise points are kept."""
        return {"descriptor": self.descriptor.name, "descriptor_params": self.descriptor.params(),
                "strategy": self.strategy.name, "scale_kind": self.scales.kind.value,
                "scale_values": list(self.scales.values), "scale_units": self.scales.units,
                "weights": self.weights.value, "max_neighbors": self.max_neighbors,
                "min_neighbors": self.min_neighbors, "keep_noise": self.keep_noise}

    def noise_codes(self):
        """The class codes whose points a run leaves out (the class table's noise classes), or
        None when it keeps every point (``keep_noise``); withheld points go with them."""
        return None if self.keep_noise else tuple(self.classes.noise)

    def kept(self, cloud):
        """(N,) bool: the points of ``cloud`` a run uses, or None when it uses all
        (:func:`lidar_sig.method.cloud.kept_points`); LidarSigError when it would use none."""
        kept = kept_points(cloud.labels, cloud.withheld, self.noise_codes())
        if kept is not None and not kept.any():
            raise LidarSigError(f"every point ({len(cloud):,}) is withheld or of a noise class "
                                f"({_codes(self.classes.noise)}); {arg('keep_noise', True)} uses them",
                                path=cloud.path)
        return kept

    def min_points(self) -> int:
        """Fewest distinct locations a cloud needs for this method: the largest k, or
        ``min_neighbors`` for radius scales (:meth:`Scales.fewest_points`)."""
        return self.scales.fewest_points(self.min_neighbors)

    def _check_size(self, cloud, n_locations, n_excluded=0):
        n = len(cloud)
        need = self.min_points()
        if n_locations < need:
            what = f"k = {need}" if self.scales.by_count else f"{need} neighbours per point"
            where = (f"{counted(n_locations, 'distinct location')} ({counted(n, 'point')})" if n_locations < n
                     else counted(n, "point"))
            if n_excluded:
                where += f" besides {counted(n_excluded, 'withheld or noise point')}"
            raise LidarSigError(f"holds {where}, fewer than the largest scale needs ({what}); use a "
                                "larger cloud or smaller scales"
                                + (f" ({arg('keep_noise', True)} uses every point)" if n_excluded else ""),
                                path=cloud.path)

    def _warm_up(self):
        """Load this run's kernels in the background (:func:`lidar_sig.base.compile.warm_up`) by a
        tiny run through them (neighbour search, descriptor, strategy: a plugin's as a
        built-in's) on a made-up patch of ground; the thread, or None for a kernel not cached
        yet (compiled in this thread then, see there) or for a descriptor that declares no
        kernels."""
        if not self.descriptor.kernels:
            # it may compile numba functions of its own that it does not declare: a warm-up
            # would compile them in a second thread beside the run's, which numba's threading
            # layer does not allow; the run's first call compiles them in its own thread
            return None

        def tiny_run():
            rng = np.random.default_rng(0)
            n = 4 * max(64, self.min_points())
            xyz = np.column_stack([rng.uniform(0.0, 10.0, n), rng.uniform(0.0, 10.0, n), rng.normal(0.0, 0.05, n)])
            index = NeighborIndex(xyz, self.scales.kind, self.scales.resolve(xyz), max_neighbors=self.max_neighbors,
                                  min_neighbors=self.min_neighbors, weights=self.weights)
            combined, _ = self.strategy.combine(self.descriptor.saliency(index.query(np.arange(n))))
            Saliency.from_values(combined)

        key = (type(self.descriptor), type(self.strategy), self.scales.kind, self.weights)
        return warm_up(key, tiny_run, self.kernels())

    def kernels(self) -> tuple[tuple[str, tuple[str, ...]], ...]:
        """The compiled kernels a run of this method calls, as (module, function names) pairs:
        those of every run, of the scales' search, of the weights, and those the descriptor and
        the strategy declare (a plugin's too)."""
        return (COMMON + self.scales.kernels + self.weights.kernels + tuple(self.descriptor.kernels)
                + tuple(self.strategy.kernels))

    def announce_compilation(self):
        """Say once per process, when this method's kernels are about to be compiled (the first
        run after installing), that they are (:func:`lidar_sig.base.compile.announce_compilation`);
        a run of tiles says it before its workers start."""
        kind = "k-nearest" if self.scales.by_count else "radii"
        announce_compilation(self.progress, self.kernels(),
                             f"{self.descriptor.name}, {self.strategy.name}, {kind}, {self.weights} weights")

    def describe(self, batch):
        """(B, 3) saliency of a NeighborhoodBatch, and the chosen scale index per point (or None)."""
        per_scale = self.descriptor.saliency(batch)
        combined, pick = self.strategy.combine(per_scale)
        return self.descriptor.refine(batch, combined, pick), pick

    def saliency(self, cloud: PointCloud, *, query: Any = None) -> tuple[Saliency, dict[str, Any]]:
        """Per-point Saliency of ``cloud`` and run statistics (undefined, capped, duplicate and
        excluded counts, scales in metres). Withheld and noise points (see ``keep_noise``) are
        left out of the run and get an undefined saliency. ``query`` ((N,) bool, optional): the
        points whose saliency is computed, their neighbours searched among all the points the
        run uses; the others get an undefined saliency (a change map's sample,
        docs/changes.md, "The points a cell's signature takes")."""
        kept = self.kept(cloud)
        if query is not None:
            query = np.asarray(query, dtype=bool)
            if query.shape != (len(cloud),):
                raise LidarSigError(f"query must be one bool per point ({len(cloud):,}), got shape {query.shape}")
        if kept is None:
            values, chosen, stats = self._saliency(cloud, 0, query)
            return Saliency.from_values(values, chosen), stats
        values, chosen, stats = self._saliency(cloud.subset(kept), int((~kept).sum()),
                                               None if query is None else query[kept])
        return Saliency.of_kept(values, chosen, kept), {**stats, "n_points": len(cloud)}

    @staticmethod
    def _area_weights(index, cloud, inverse):
        """The area weights of ``index``'s locations (``inverse``: each point's, or None), with the
        cap a run in tiles finds too (:func:`~lidar_sig.numerics.neighbors.set_area_cap`)."""
        second = index.second_distances()
        sampled = None
        share = cap_share(len(cloud))
        if share < 1.0:  # the sample's windows are placed by each point's x, y; copies share theirs
            inside = in_cap_windows(cloud.xyz[:, :2] * np.asarray(cloud.units.factors[:2]), share)
            sampled = np.zeros(len(index.xyz), bool)
            sampled[np.flatnonzero(inside) if inverse is None else inverse[inside]] = True
            sampled = sampled[index.order]
        return index.area_weights(set_area_cap(second, sampled), second)

    def _saliency(self, cloud, n_excluded, query=None):
        """(N, 3) saliency values and (N,) chosen scales (or None) of every point of ``cloud``
        (the points a run uses), or of the points ``query`` alone (the others NaN), and the
        run statistics."""
        self.announce_compilation()
        load_kernels(self.kernels())
        warming = self._warm_up()
        with step("neighbourhoods", enabled=self.progress, points=len(cloud),
                  scales=self.scales.describe(), weights=self.weights) as s:
            xyz = cloud.metric_xyz()
            support, inverse = unique_points(xyz)
            self._check_size(cloud, len(support), n_excluded)
            scales = self.scales.resolve(support)
            index = NeighborIndex(support, self.scales.kind, scales, max_neighbors=self.max_neighbors,
                                  min_neighbors=self.min_neighbors)  # the voxel grid: numpy only
            if warming is not None:
                warming.join()  # the kernels are loaded: from here on this thread runs them
            self.descriptor.prepare(support, self.scales.kind, scales, max_neighbors=self.max_neighbors,
                                    min_neighbors=self.min_neighbors, progress=self.progress)
            if self.weights.by_area:
                index.weights = self._area_weights(index, cloud, inverse)
            s.note(locations=len(support))
        m = len(support)
        values = np.empty((m, 3)) if query is None else np.full((m, 3), np.nan)
        chosen = None
        n_capped = 0
        searching = describing = 0.0  # seconds, for --verbose: the two interleave per block
        with step(f"saliency ({self.descriptor.name} {self.strategy.name})", enabled=self.progress) as s:
            if query is None:
                blocks = index.blocks()
            else:  # the locations of the points asked for, in the index's order
                wanted = np.zeros(m, bool)
                wanted[np.flatnonzero(query) if inverse is None else inverse[query]] = True
                blocks = index.blocks(index.rows_of(np.flatnonzero(wanted)))
            for rows in s.track(blocks, unit="block"):
                t0 = time.perf_counter()
                batch = index.query(rows)
                t1 = time.perf_counter()
                combined, pick = self.describe(batch)
                describing += time.perf_counter() - t1
                searching += t1 - t0
                values[batch.ids] = combined
                if pick is not None:
                    if chosen is None:
                        chosen = np.full(m, -1, dtype=np.int64)
                    chosen[batch.ids] = pick
                n_capped += int(batch.capped.sum())
            s.note(blocks=len(blocks), neighbour_search=f"{searching:.2f} s",
                   descriptor=f"{describing:.2f} s", capped=n_capped)
        if inverse is not None:  # every copy of a location takes its saliency
            values = values[inverse]
            chosen = chosen[inverse] if chosen is not None else None
        n = len(cloud)
        if query is not None:  # a copy not asked for stays undefined, as the points not asked for
            values[~query] = np.nan
            if chosen is not None:
                chosen[~query] = -1
        n_asked = n if query is None else int(query.sum())
        n_undefined = int(nan_rows(values).sum()) - (n - n_asked)
        if n_undefined == n_asked:
            # k counts points; normalized radii are also said in metres
            metres = f" (= {_fmt(scales)} m)" if self.scales.normalized else ""
            larger = "a larger k" if self.scales.by_count else "larger radii"
            raise LidarSigError(
                f"no point has a defined saliency: every neighbourhood at {self.scales.describe()}{metres} "
                f"holds fewer than the {self.min_neighbors} points a saliency needs; use {larger}",
                path=cloud.path)
        if n_capped > CAPPED_WARNING * m:
            warnings.warn(
                f"{cloud.path or 'the cloud'}: {n_capped:,} of {m:,} neighbourhoods hold more than {self.max_neighbors} "
                f"points within the largest radius ({scales.max():.4g} m) and were cut to the nearest "
                f"{self.max_neighbors}: the radii are large for this cloud"
                + (" (normalized radii follow the bounding box, which a far outlier inflates)"
                   if self.scales.normalized else "")
                + "; use smaller radii or the default k-nearest scales", LidarSigWarning, stacklevel=2)
        stats = {"n_points": n, **({} if query is None else {"n_queried": n_asked}), "n_undefined": n_undefined, "n_capped": n_capped,
                 "n_duplicates": n - m, "n_excluded": n_excluded, "resolved_scales": scales.tolist(),
                 "units": cloud.units.describe(), "metres_per_unit": list(cloud.units.factors),
                 **self.method()}
        return values, chosen, stats

    def run(self, cloud: Any, *, labels: Any = None, columns: Any = None, execution: Execution | None = None) -> Result:
        """Saliency and signature of ``cloud``: a PointCloud, a path (``columns`` names the
        columns of a text file), an (N, 3) array of coordinates in metres (with optional
        ``labels``, one class code per point) or an Open3D point cloud.

        A LAS/LAZ file that one block would hold above the memory budget of ``execution`` (a
        :class:`lidar_sig.Execution`; default 1 GiB per process), or any LAS/LAZ file when the
        execution asks for tiles (a ``tile_size``, ``workers`` or a ``scheduler``), is processed
        in tiles with halos, with the same results, its scratch files in a new folder inside
        the execution's ``work_dir`` (default the temporary folder): the Result then keeps its
        per-point values on disk, in tiles, until they are asked for, and ``write`` streams them
        into a LAS/LAZ file (docs/scale-out.md). The file's header alone decides, before any
        point is read."""
        from ..tiling.execution import as_execution

        execution = as_execution(execution)
        if isinstance(cloud, (str, os.PathLike)):
            n = execution.over_budget(cloud, self)
            if n is not None or execution.tiles_asked:
                return in_tiles(self, cloud, execution, n_points=n)
        elif execution.tiles_asked:
            raise LidarSigError(f"tiles are made of a LAS/LAZ file: give its path to run {a_kind(cloud)} in tiles, "
                                f"or leave out {arg('tile_size')}, {arg('workers')} and {arg('scheduler')}")
        cloud = as_point_cloud(cloud, labels, columns)
        sal, stats = self.saliency(cloud)
        classes = self.classes if cloud.labels is not None else UNLABELED
        codes = cloud.labels if cloud.labels is not None else np.zeros(len(cloud), np.int64)
        metadata = {"lidar_sig_version": __version__, "source": cloud.path,
                    "scales": self.scales.describe(), "crs": cloud.crs, **stats}
        # what the signature is made of, as it is now (the metadata copied: a caller may add to
        # the Result's own before asking for the signature)
        make = partial(_signature_of, sal, classes, codes, self.frame, self.kept(cloud), dict(metadata),
                       self.progress)
        return Result(cloud, sal, metadata=metadata, make_signature=make)


def in_tiles(pipeline: Pipeline, source: str | os.PathLike[str], execution: Execution, *, n_points: int | None,
             work: str | os.PathLike[str] | None = None,
             outputs: Sequence[str | os.PathLike[str]] = ()) -> TiledResult:
    """One LAS/LAZ file run in tiles (:func:`lidar_sig.tiling.run_set.run_in_tiles`: its
    ``n_points`` points exceed the memory budget of ``execution`` as one block, or tiles were
    asked for), as a :class:`TiledResult` whose per-point values stay in the work folder
    (``work``, a job's; else a new folder of its own) until asked for; ``outputs`` are the
    job's, which the work folder must not hold."""
    from ..tiling.run_set import run_in_tiles

    return TiledResult(run_in_tiles(pipeline, source, execution, n_points=n_points, work=work, outputs=outputs))


def _signature_of(sal, classes, codes, frame, kept, metadata, progress):
    """The Signature of a run's Saliency ``sal`` (:meth:`Pipeline.run`, when first asked for)."""
    with step("signature", enabled=progress, classes=classes.name):
        return Signature.from_saliency(sal.values, classes.index(codes), classes=classes, frame=frame,
                                       egeom=sal.egeom, metadata=metadata, kept=kept)


def pipeline_or_default(pipeline: Pipeline | None) -> Pipeline:
    """``pipeline``, or ``Pipeline()`` for None; a LidarSigError naming anything else (the
    functions that take an optional pipeline check it where it is given)."""
    if pipeline is None:
        return Pipeline()
    if not isinstance(pipeline, Pipeline):
        raise LidarSigError(f"pipeline must be a lidar_sig.Pipeline, got {pipeline!r}")
    return pipeline


def as_point_cloud(cloud: Any, labels: Any = None, columns: str | Sequence[str] | None = None) -> PointCloud:
    """A PointCloud from what :meth:`Pipeline.run` accepts (see there)."""
    if isinstance(cloud, PointCloud):
        if labels is not None:
            raise LidarSigError("labels are given with a PointCloud: set PointCloud.labels instead")
        return cloud
    if is_open3d(cloud):
        return from_open3d(cloud)
    if isinstance(cloud, np.ndarray):
        return PointCloud(cloud, labels)
    if isinstance(cloud, (str, os.PathLike)):
        from ..io import read

        return read(cloud, columns=columns)
    raise LidarSigError(f"cannot run on {a_kind(cloud)}; give a PointCloud, a file path, an "
                        "(N, 3) numpy array or an Open3D point cloud")


def _codes(codes):
    return "class " + ", ".join(str(c) for c in codes) if codes else "no noise class"


def _fmt(values):
    return ", ".join(f"{v:.4g}" for v in np.asarray(values).tolist())
