"""Neighbourhoods (docs/method.md, "Neighbourhoods and scales"): one query at the largest scale, in blocks of points.

Every scale of a run is a prefix of the neighbour list of its largest scale, so one search per
block of points serves them all. The search runs on a voxel grid (:mod:`lidar_sig.numerics._voxels`); the
few queries it cannot settle within a few voxel shells (isolated outliers) go to a scan of every
point (a few queries) or a k-d tree; k-nearest queries and the area weights' search are first
searched again with more shells when that is cheap.
The grid's kernels (numba) are loaded when a first index is built, the k-d tree (scipy) when a
query needs it: importing this module loads neither.
The index works on the points sorted by voxel: ``NeighborIndex.xyz`` is the sorted cloud and
``order`` maps its rows back to the input.

Neighbours can be weighted by the area they stand for (``weights="area"``): the squared distance
to a point's second-nearest other point, capped at ``AREA_CAP`` times the cloud's median of that
distance (above ``CAP_POINTS`` points, the median of a sample of windows). A neighbourhood's tensor then estimates the sampled surface rather than the scan
pattern: where points cluster (overlapping strips, a random thinning) each counts less, where
they are sparse each counts more. The weights use distances only, so they are invariant to
rotation, translation, uniform scaling and point order. docs/comparison.md has the measurements
that chose them.
"""
from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass
from enum import StrEnum

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .sorting import stable_order

# Bytes of neighbour lists (squared distance + index) held at once; bounds memory per block. Small
# enough that the descriptor reads a block's lists from the cache the search wrote them to
# (larger blocks were slower: docs/performance.md).
_BLOCK_BYTES = 24 * 2**20
# Voxel shells a k-nearest query may grow in a first search (then see _FARTHER_VOXELS).
_KNN_SHELLS = 6
# Queries x points up to which unsettled k-nearest queries scan every point instead of building a
# k-d tree: for a handful of queries the scan is the cheaper (docs/performance.md).
_SCAN_ALL = 50_000_000
# Voxels the queries left unsettled by the shells may list in all, growing twice as many shells,
# before a scan or the k-d tree takes them: a few isolated points settle so far sooner than by a
# scan of every point (docs/performance.md); thousands of spikes would list millions of voxels and
# go to the tree.
_FARTHER_VOXELS = 2**22


class ScaleKind(StrEnum):
    """How the scales of a run measure a neighbourhood (docs/method.md, "Neighbourhoods and
    scales"): by a radius around x_i (``"radius"``) or by a count of nearest points (``"knn"``);
    the text is what metadata and archives record. What differs between the two kinds is said
    here, so that no other module tells them apart by their text."""

    RADIUS = "radius"
    KNN = "knn"

    def __repr__(self) -> str:
        return repr(self.value)  # as the text it stands for: Scales(kind='knn', ...)

    @property
    def by_count(self) -> bool:
        """True for k-nearest scales: a scale is a whole number of points, not a distance."""
        return self is ScaleKind.KNN

    @property
    def unit(self) -> str:
        """The unit of resolved scales for people: ``k`` (points) or ``m`` (metres)."""
        return "k" if self.by_count else "m"

    @property
    def resolved_units(self) -> str:
        """The unit of resolved scales in words, as archives record it: neighbours or metres."""
        return "neighbours" if self.by_count else "metres"

    def typed(self, values: Iterable[float]) -> list[int] | list[float]:
        """``values`` (resolved or given scales) as plain numbers of this kind: ints for k, floats for radii."""
        return [int(v) for v in values] if self.by_count else [float(v) for v in values]

    def describe(self, resolved: Iterable[float]) -> str:
        """Resolved scales for people: ``k 20, 30, 40`` or ``radii 0.5, 1 m``."""
        if self.by_count:
            return "k " + ", ".join(str(int(v)) for v in resolved)
        return "radii " + ", ".join(f"{v:.4g}" for v in resolved) + " m"


class Weights(StrEnum):
    """How neighbours count in a neighbourhood's tensor: by the area each stands for
    (``"area"``, the module docstring) or alike (``"none"``, plain means, the paper's)."""

    AREA = "area"
    NONE = "none"

    def __repr__(self) -> str:
        return repr(self.value)

    @property
    def by_area(self) -> bool:
        """True when each neighbour counts by the area it stands for (its second-neighbour distance)."""
        return self is Weights.AREA

    @property
    def kernels(self) -> tuple[tuple[str, tuple[str, ...]], ...]:
        """The compiled kernels these weights call, as (module, function names): the area
        weights' third-nearest search."""
        return (("lidar_sig.numerics._voxels", ("third_nearest",)),) if self.by_area else ()


#: The neighbour weights by name, as options give them ("area" first: the default).
WEIGHTS = tuple(w.value for w in Weights)
#: k-nearest neighbourhoods take every point tied with the k-th neighbour (squared distance
#: within this relative tolerance): coordinates quantized to LAS steps tie often, and which of
#: two tied points is "the k-th" would otherwise depend on round-off (a rotation, a unit
#: conversion) and point order. Likewise a point at a sphere's radius, to this tolerance, is in.
#: It covers the round-off of coordinates as large as UTM northings (about 1e-9 m) at neighbour
#: distances down to a centimetre, and is far below any LAS coordinate step (0.25 um at 0.5 m).
TIE = 1e-6
#: Room for neighbours tied with the largest k's k-th, beyond it. The search lists one past the
#: k-th, and the room only where that one ties (grid.nearest): ties are rare on real clouds
#: (AHN3 cropped_1 at k = 40: 28 of 640,510 rows), so the room costs nearly nothing.
TIE_SLACK = 8
#: Area weights are capped at (AREA_CAP x the median second-neighbour distance)^2, so that an
#: isolated point cannot dominate the neighbourhoods it falls in.
AREA_CAP = 4.0


def tie_limit(d2):
    """The tie rule (:data:`TIE`): the largest squared distance that counts as ``d2``, a k-th
    neighbour's squared distance or a sphere's squared radius; (1 + TIE) d2."""
    return d2 * (1.0 + TIE)


def radius_reach(radius):
    """The tie rule as a distance: how far from x_i a neighbour within ``radius`` (metres, or
    an array of them) can lie, ties included; radius sqrt(1 + TIE)."""
    return radius * math.sqrt(1.0 + TIE)


def counts_within(d2, n, limits):
    """(B, S) neighbours of each row within each limit: how many of the first ``n[b]`` squared
    distances of row ``b`` of ``d2`` are at most ``limits[b, s]`` (``limits`` (B, S), or (S,)
    for every row; ascending). Rows are sorted by distance or grouped by scale, as the search
    lists them. Every count of neighbours within a scale is this."""
    from ._voxels import count_within

    limits = np.ascontiguousarray(np.broadcast_to(np.asarray(limits, dtype=np.float64),
                                                  (len(n), np.shape(limits)[-1])))
    counts = np.empty(limits.shape, np.int64)
    count_within(d2, np.asarray(n, dtype=np.int64), limits, counts)
    return counts


#: Above this many points a set's area-weight cap comes from a sample of its locations: those in
#: plan-view windows of CAP_WINDOW metres that a hash of the window's place picks, a share
#: CAP_POINTS / n of them, each distance taken up to CAP_REACH metres. The sample is a function of
#: where the points are, so one block and any tiling find the same cap, and a run in tiles
#: searches the second neighbours of the sample's few windows only (docs/method.md, "Neighbour
#: weights").
CAP_POINTS = 1_000_000
CAP_WINDOW = 10.0
CAP_REACH = 5.0


def area_cap(second_distances):
    """The cap of the second-neighbour distance behind area weights (coordinate units): AREA_CAP
    times the median of ``second_distances`` (every distinct location's)."""
    return AREA_CAP * float(np.median(second_distances))


def cap_share(n_points):
    """The share of the windows whose locations give the area-weight cap of a set of ``n_points``
    points (1: every location; :data:`CAP_POINTS`)."""
    return min(1.0, CAP_POINTS / max(int(n_points), 1))


def in_cap_windows(xy, share, reach=0.0):
    """(N,) True where the plan-view points ``xy`` (N, 2) (metres from the CRS's origin: the
    files' coordinates times metres per unit) lie within ``reach`` metres (less than
    CAP_WINDOW) of a window of the cap's sample of ``share`` (:data:`CAP_POINTS`): a window
    is in when the hash of its place is (:mod:`~lidar_sig.numerics.hashing`)."""
    from .hashing import below_share, hash2

    xy = np.asarray(xy, dtype=np.float64)
    if share >= 1.0:
        return np.ones(len(xy), bool)
    lo = np.floor((xy - reach) / CAP_WINDOW).astype(np.int64)
    hi = np.floor((xy + reach) / CAP_WINDOW).astype(np.int64)
    out = below_share(hash2(lo[:, 0], lo[:, 1]), share)
    if reach:  # the reach may cross into the windows east, north and north-east
        for ix, iy in ((hi, lo), (lo, hi), (hi, hi)):
            out |= below_share(hash2(ix[:, 0], iy[:, 1]), share)
    return out


def sampled_area_cap(second_distances):
    """The area-weight cap from the sample's second-neighbour distances (metres; those found
    beyond CAP_REACH need only be beyond it): AREA_CAP times the median of each taken up to
    CAP_REACH, or None when the sample holds no location."""
    if not len(second_distances):
        return None
    return area_cap(np.minimum(second_distances, CAP_REACH))


def set_area_cap(second_distances, sampled=None):
    """The area-weight cap (metres) of a set run as one block, from every distinct location's
    second-neighbour distance and, above :data:`CAP_POINTS` points, the (L,) mask of the
    locations in the sample's windows (:func:`in_cap_windows`): from those (every location when
    they are none, or without a mask), as a run in tiles finds it."""
    cap = None if sampled is None else sampled_area_cap(second_distances[sampled])
    return area_cap(second_distances) if cap is None else cap


@dataclass
class NeighborhoodBatch:
    """Neighbourhoods of a block of query points (all indices refer to the sorted cloud).

    Attributes
    ----------
    xyz : (N, 3) float64
        The whole cloud, centred and sorted by voxel (``NeighborIndex.xyz``).
    rows : (B,) int64
        Query points x_i.
    ids : (B,) int64
        The same points' indices in the input cloud.
    idx : (B, K) int64
        Neighbours; k-nearest lists are sorted by distance, spherical ones grouped by scale
        (scale s a prefix of scale s + 1). Row b holds ``n[b]`` of them; the rest of the row
        is undefined.
    d2 : (B, K) float64
        Squared distances matching ``idx`` (``dist`` gives the distances).
    n : (B,) int64
        Neighbours found at the largest scale.
    counts : (B, S) int64
        Neighbours within each scale, x_i included (a prefix length of ``idx``); 0 where fewer
        than ``min_neighbors`` (undefined saliency).
    sigma : (B, S) float64
        Scale radius per point: the radius, or for k-nearest scales the distance to the k-th
        neighbour (the Gaussian decay of tensor voting).
    capped : (B,) bool
        Spherical neighbourhoods cut at ``max_neighbors`` nearest.
    weights : (N,) float64
        Weight of every point of the cloud as a neighbour (sorted order); empty when neighbours
        count equally.
    kind : ScaleKind
        The kind of scales.
    """

    xyz: np.ndarray
    rows: np.ndarray
    ids: np.ndarray
    idx: np.ndarray
    d2: np.ndarray
    n: np.ndarray
    counts: np.ndarray
    sigma: np.ndarray
    capped: np.ndarray
    weights: np.ndarray
    kind: ScaleKind

    @property
    def dist(self) -> NDArray[np.float64]:
        """(B, K) distances matching ``idx``; inf past ``n``."""
        listed = np.arange(self.d2.shape[1])[None, :] < self.n[:, None]
        # past n a row holds whatever its buffer held before: not a distance to take the root of
        return np.where(listed, np.sqrt(np.where(listed, self.d2, 0.0)), np.inf)

    def reach(self) -> NDArray[np.float64]:
        """(B,) how far from x_i its neighbourhood at the largest scale can reach, ties
        included: no point farther away can be in it, however many points are added beyond
        (a tile checks its halo with this). The largest radius, or the distance to the last
        neighbour listed, stretched by the tie rule."""
        if self.kind.by_count:
            last = self.d2[np.arange(len(self.n)), np.maximum(self.n, 1) - 1]
            return np.sqrt(tie_limit(last))
        return radius_reach(self.sigma[:, -1])


class NeighborIndex:
    """Neighbour search over a cloud at a set of resolved scales, block by block.

    Parameters
    ----------
    xyz : (N, 3) float64
        Coordinates, preferably centred (the search and the kernels only see differences).
    kind : ScaleKind or {"radius", "knn"}
    scales : (S,) array
        Radii in coordinate units, or k values; ascending.
    max_neighbors : int
        Cap of a spherical neighbourhood (nearest first), docs/method.md, "Neighbourhoods and scales"; default 512.
    min_neighbors : int
        A scale holding fewer neighbours (x_i included) gets count 0: undefined saliency.
    weights : Weights or {"none", "area"}
        How neighbours count (module docstring); "none" by default.
    area_cap : float, optional
        Cap of the second-neighbour distance behind area weights, in coordinate units; by
        default ``AREA_CAP`` times this cloud's median. A tile of a larger set passes the set's
        cap, so that its weights are those of the whole set.
    second : (N,) array, optional
        Each point's second-neighbour distance when it is known already (a tile of a set passes
        the whole set's, found by an earlier pass): area weights then take it instead of
        searching again.
    shells : int, optional
        Voxel shells a k-nearest query may grow (default 6); an unsettled query is searched
        again with twice as many when few are, then goes to a scan or the k-d tree.
    """

    def __init__(self, xyz: ArrayLike, kind: ScaleKind | str, scales: ArrayLike, *, max_neighbors: int = 512,
                 min_neighbors: int = 3, weights: Weights | str = "none", area_cap: float | None = None,
                 second: ArrayLike | None = None, shells: int = _KNN_SHELLS) -> None:
        from ._voxels import VoxelGrid

        xyz = np.asarray(xyz, dtype=np.float64)
        self.kind = ScaleKind(kind)
        self.scales = np.asarray(scales)
        self.max_neighbors = int(max_neighbors)
        self.min_neighbors = int(min_neighbors)
        n = len(xyz)
        density, volume = _robust_density(xyz)
        # Spheres expected to hold far more than the cap are served by a k-nearest search of
        # cap + 1, cut at the radii: the same neighbourhoods (the nearest max_neighbors within
        # the radius), without scanning every point of a huge sphere (radii inflated by an outlier).
        by_count = self.kind.by_count
        self.capped_search = (not by_count
                              and density * np.pi * float(self.scales.max()) ** 2 > 2 * self.max_neighbors)
        if by_count or self.capped_search:
            want = self.scales.max() + TIE_SLACK if by_count else self.max_neighbors + 1
            self.width = int(min(want, n))
            cell = _knn_cell(self.width, density, volume)
            self.s_max = int(shells)
        else:
            self.width = min(self.max_neighbors, n)
            # a voxel as large as the radius stretched by the tie rule: its 27 neighbours hold the
            # sphere, even for a query on a voxel's face
            cell = radius_reach(float(self.scales.max()))
            self.s_max = 1
        self.grid = VoxelGrid(xyz, cell)
        self.xyz = self.grid.points
        self.order = self.grid.order
        self._tree = None
        self._buffers = None
        known = None if second is None else np.asarray(second, dtype=np.float64)[self.order]
        self.weights = self.area_weights(area_cap, known) if Weights(weights).by_area else np.empty(0)

    def rows_of(self, ids: ArrayLike) -> NDArray[np.int64]:
        """Sorted-order rows of input point indices ``ids``."""
        inverse = np.empty_like(self.order)
        inverse[self.order] = np.arange(len(self.order))
        return inverse[np.asarray(ids)]

    def block_size(self) -> int:
        """Query points per block so that one block's neighbour lists fit in _BLOCK_BYTES."""
        return max(1024, _BLOCK_BYTES // (16 * self.width))

    def blocks(self, rows: ArrayLike | None = None) -> list[NDArray[np.int64]]:
        """Consecutive blocks of query rows (sorted order) covering the cloud, or ``rows``."""
        step = self.block_size()
        if rows is None:
            n = len(self.xyz)
            return [np.arange(s, min(n, s + step)) for s in range(0, n, step)]
        rows = np.sort(np.asarray(rows, dtype=np.int64))  # sorted rows keep voxel locality
        return [rows[s:s + step] for s in range(0, len(rows), step)]

    def query(self, rows: ArrayLike) -> NeighborhoodBatch:
        """Neighbourhoods of the sorted-order points ``rows`` at every scale.

        The arrays of the returned batch live in buffers reused by the next call.
        """
        rows = np.asarray(rows, dtype=np.int64)
        b = len(rows)
        if self._buffers is None or self._buffers[0].shape[0] < b:
            rows_held = max(b, min(self.block_size(), len(self.xyz)))  # a block, or the whole of a small cloud
            self._buffers = (np.empty((rows_held, self.width)), np.empty((rows_held, self.width), dtype=np.int64))
        d2, idx = self._buffers[0][:b], self._buffers[1][:b]
        n = np.zeros(b, np.int64)
        total = np.zeros(b, np.int64)
        done = np.zeros(b, np.bool_)
        by_count = self.kind.by_count
        radii2 = None if by_count else tie_limit(self.scales.astype(np.float64) ** 2)
        if by_count:
            # the k + 1 nearest, the row's room only where ties with the k-th run on, and each
            # row's scales counted by the search while the row is at hand (grid.nearest); n is
            # then the count of the largest scale: neighbours past its ties are not needed
            ks = np.asarray(self.scales, dtype=np.int64)
            counts, sigma = np.empty((b, len(ks)), np.int64), np.empty((b, len(ks)))
            self.grid.search(rows, d2, idx, n, total, done, ks=ks, s_max=self.s_max, tie_factor=tie_limit(1.0),
                             counts=counts, sigma=sigma)
        elif self.capped_search:
            self.grid.search(rows, d2, idx, n, total, done, ks=np.array([self.width]), s_max=self.s_max)
        else:
            self.grid.search(rows, d2, idx, n, total, done, cap=self.width, s_max=self.s_max, radii2=radii2)
        if by_count and not done.all():
            self._farther(rows, d2, idx, n, total, done, ks, counts, sigma)
        if not done.all():
            todo = np.flatnonzero(~done)
            self._complete(rows, d2, idx, n, total, done, self.width, nearest=by_count or self.capped_search)
            if by_count:  # the rows listed outside the search: their scales counted here
                counts[todo], sigma[todo] = _knn_counts(d2[todo], n[todo], ks)
                n[todo] = counts[todo, -1]
        if by_count:
            capped = np.zeros(b, bool)
        else:
            if self.capped_search:
                counts, total, n = _cut_at_radii(d2, n, radii2, self.max_neighbors)
            else:
                counts = counts_within(d2, n, radii2)
            sigma = np.broadcast_to(self.scales[None, :].astype(np.float64), counts.shape)
            capped = total > self.max_neighbors
        width = max(1, int(n.max()))
        d2, idx = d2[:, :width], idx[:, :width]
        counts[counts < self.min_neighbors] = 0  # too few for a defined saliency
        return NeighborhoodBatch(self.xyz, rows, self.order[rows], idx, d2, n, counts,
                                 np.ascontiguousarray(sigma), capped, self.weights, self.kind)

    def area_weights(self, cap: float | None = None,
                     d_second: NDArray[np.float64] | None = None) -> NDArray[np.float64]:
        """(N,) weight of each point as a neighbour, sorted order: the squared distance to its
        second-nearest other point (``d_second``, sorted order, when known), capped at ``cap``
        (default AREA_CAP x its median), squared (module docstring).

        Exact duplicate points give zero distances; the pipeline merges them beforehand.
        """
        if d_second is None:
            d_second = self.second_distances()
        if cap is None:
            cap = area_cap(d_second)
        weights = np.minimum(d_second, cap)
        return np.multiply(weights, weights, out=weights)  # squared in place: one array, not two

    def second_distances(self, rows: ArrayLike | None = None, *, shells: int = _KNN_SHELLS) -> NDArray[np.float64]:
        """Distance from each point (sorted order; ``rows`` only, if given) to its second-nearest
        other point, in coordinate units (in a cloud of fewer than 3 points, to its farthest).
        ``shells``: voxel shells a query may grow before a second search (see ``_farther``)
        or the k-d tree."""
        n = len(self.xyz)
        k = min(3, n)  # the point itself and two others
        rows = np.arange(n) if rows is None else np.asarray(rows, dtype=np.int64)
        d_second = np.zeros(len(rows))
        if k == 3:  # no candidate lists: each query keeps its three nearest as it scans
            third, done = np.empty(len(rows)), np.zeros(len(rows), np.bool_)
            self.grid.third_distances(rows, third, done, s_max=int(shells))
            todo = np.flatnonzero(~done)
            s_far = self._farther_shells(len(todo), shells) if len(todo) else 0
            if s_far:  # isolated points: again, alone, with more shells when that is cheap (_farther)
                far, settled = np.empty(len(todo)), np.zeros(len(todo), np.bool_)
                self.grid.third_distances(rows[todo], far, settled, s_max=s_far)
                third[todo[settled]] = far[settled]
                todo = todo[~settled]
            if len(todo):
                d2, idx = np.empty((len(todo), k)), np.empty((len(todo), k), np.int64)
                found, total = np.zeros(len(todo), np.int64), np.zeros(len(todo), np.int64)
                self._complete(rows[todo], d2, idx, found, total, done[todo], k, nearest=True)
                third[todo] = d2[:, k - 1]
            return np.sqrt(third, out=third)
        step = self.block_size()
        for start in range(0, len(rows), step):
            part = slice(start, start + step)
            block = rows[part]
            b = len(block)
            d2, idx = np.empty((b, k)), np.empty((b, k), np.int64)
            found, done = np.zeros(b, np.int64), np.zeros(b, np.bool_)
            total = np.zeros(b, np.int64)
            self.grid.search(block, d2, idx, found, total, done, ks=np.array([k]), s_max=int(shells))
            if not done.all():
                self._complete(block, d2, idx, found, total, done, k, nearest=True)
            d_second[part] = np.sqrt(d2[:, k - 1])
        return d_second

    def _kdtree(self):
        if self._tree is None:
            from scipy.spatial import cKDTree  # slow to load, and most runs leave no query to it

            self._tree = cKDTree(self.xyz)
        return self._tree

    def _farther_shells(self, n_todo, shells):
        """Shells the ``n_todo`` queries a search of ``shells`` shells left unsettled may grow to
        in a second search (twice as many), or 0 when their voxels would exceed _FARTHER_VOXELS
        in all or, per query, the points a scan visits."""
        s = 2 * int(shells)
        per_query = (2 * s + 1) ** 3
        return s if n_todo * per_query <= _FARTHER_VOXELS and per_query <= len(self.xyz) else 0

    def _farther(self, rows, d2, idx, n, total, done, ks, counts, sigma):
        # k-nearest rows the search left unsettled (isolated points): searched again, alone,
        # with more shells when that is cheap; the k-th's ties and the counts as in the search
        todo = np.flatnonzero(~done)
        s_far = self._farther_shells(len(todo), self.s_max)
        if not s_far:
            return
        t = len(todo)
        far_d2, far_idx = np.empty((t, self.width)), np.empty((t, self.width), np.int64)
        far_n, far_total, far_done = np.zeros(t, np.int64), np.zeros(t, np.int64), np.zeros(t, np.bool_)
        far_counts, far_sigma = np.empty((t, len(ks)), np.int64), np.empty((t, len(ks)))
        self.grid.search(rows[todo], far_d2, far_idx, far_n, far_total, far_done, ks=ks, s_max=s_far,
                         tie_factor=tie_limit(1.0), counts=far_counts, sigma=far_sigma)
        d2[todo], idx[todo], n[todo], total[todo], done[todo] = far_d2, far_idx, far_n, far_total, far_done
        counts[todo], sigma[todo] = far_counts, far_sigma

    def _complete(self, rows, d2, idx, n, total, done, width, nearest):
        # Queries the voxel shells could not settle (isolated points far from the rest), listed
        # sorted by distance: a few by a scan of every point, more by a k-d tree. ``nearest``:
        # the ``width`` nearest are wanted; else those within the largest radius.
        todo = np.flatnonzero(~done)
        if nearest and len(todo) * len(self.xyz) <= _SCAN_ALL:
            from numba import get_num_threads

            from ._voxels import nearest_by_scan

            nearest_by_scan(self.xyz, rows[todo], width, get_num_threads(), d2, idx, n, todo)
            return
        q = self.xyz[rows[todo]]
        if nearest:
            dist, nb = self._kdtree().query(q, k=width)
        else:
            bound = radius_reach(float(self.scales.max()))
            dist, nb = self._kdtree().query(q, k=width, distance_upper_bound=bound)
        dist, nb = dist.reshape(len(todo), -1), nb.reshape(len(todo), -1)
        found = np.isfinite(dist)
        n[todo] = found.sum(1)
        d2[todo] = np.where(found, dist * dist, np.inf)
        idx[todo] = np.where(found, nb, -1)
        if not nearest:
            # a full list may hide more points inside the sphere: ask for one more
            full = todo[n[todo] == width]
            if len(full):
                more, _ = self._kdtree().query(self.xyz[rows[full]], k=width + 1,
                                               distance_upper_bound=bound)
                total[full] = np.isfinite(more).sum(1)
            total[todo] = np.maximum(total[todo], n[todo])


def unique_points(xyz):
    """The distinct locations of ``xyz`` and, if any repeat, each point's location.

    Returns ``(support, inverse)`` with ``support[inverse] == xyz``; ``inverse`` is None (and
    ``support`` is ``xyz`` itself) when no two points coincide, the usual case. Points are
    grouped by sorting one 64-bit hash of their coordinates' bits (cheaper than sorting three
    columns); equal hashes are then compared coordinate by coordinate.
    """
    xyz = np.ascontiguousarray(xyz, dtype=np.float64)
    bits = (xyz + 0.0).view(np.uint64)  # + 0.0 turns -0.0 into 0.0: equal places, equal bits
    with np.errstate(over="ignore"):
        key = ((bits[:, 0] * np.uint64(0x9E3779B97F4A7C15)) ^ (bits[:, 1] * np.uint64(0xC2B2AE3D27D4EB4F))
               ^ (bits[:, 2] * np.uint64(0x165667B19E3779F9)))
    order = stable_order(key)
    key = key[order]
    candidates = np.flatnonzero(key[1:] == key[:-1]) + 1
    if not len(candidates):
        return xyz, None
    new = np.ones(len(xyz), bool)
    new[candidates] = np.any(xyz[order[candidates]] != xyz[order[candidates - 1]], axis=1)
    if new.all():
        return xyz, None
    inverse = np.empty(len(xyz), np.int64)
    inverse[order] = np.cumsum(new) - 1
    return xyz[order[new]], inverse


def _knn_counts(d2, n, ks):
    """Neighbours per k-nearest scale, ties with the k-th included, and the k-th distances.

    ``d2`` (B, W) squared distances sorted ascending, ``n`` (B,) valid per row, ``ks`` (S,).
    Returns counts (B, S) and sigma (B, S), the distance to the k-th neighbour (to the last
    where a row holds fewer than k; 0 in an empty row).
    """
    from ._voxels import count_ties

    ks = np.asarray(ks, dtype=np.int64)
    counts, sigma = np.empty((len(d2), len(ks)), np.int64), np.empty((len(d2), len(ks)))
    count_ties(d2, np.asarray(n, dtype=np.int64), ks, tie_limit(1.0), counts, sigma)  # the rule as a factor
    return counts, sigma


def _cut_at_radii(d2, n, radii2, cap):
    """Spherical neighbourhoods from sorted k-nearest lists of cap + 1: counts (B, S) within each
    squared radius (``radii2``, ties included) among the cap nearest, the number within the
    largest as far as the list tells (cap + 1 when even the last is inside: the sphere was
    capped), and the list lengths."""
    total = counts_within(d2, n, radii2[-1:])[:, 0]
    keep = np.minimum(total, cap)
    return counts_within(d2, keep, radii2), total, keep


def _robust_density(xyz):
    """(points per square metre, cubic metres) of the cloud's core: the box between the 1st and
    99th percentiles of each axis (from at most 100,000 points), so that far outliers inflate
    neither. Airborne clouds are nearly 2.5D: the density is over the two longest sides."""
    sample = xyz[:: max(1, len(xyz) // 100_000)]
    lo, hi = np.percentile(sample, [1, 99], axis=0)
    inside = np.all((sample >= lo) & (sample <= hi), axis=1).mean() * len(xyz)
    extent = np.sort(np.maximum(hi - lo, 1e-9))[::-1]
    return max(inside, 1.0) / max(extent[0] * extent[1], 1e-12), float(np.prod(extent))


def _knn_cell(k, density, volume):
    """Voxel side for k-nearest search: 1.5 times the k-th neighbour distance at the cloud's
    density, so that most queries find their k nearest within the voxels next to theirs (a poor
    guess costs time, never correctness; docs/performance.md has the measurements). Not smaller than the side at
    which the core box holds more voxels than the grid's dense look-up table (small k on a tall
    box would otherwise fall back to binary searches)."""
    from ._voxels import LUT_CELLS

    cell = 1.5 * np.sqrt(k / (np.pi * density))
    cell = max(cell, (volume / LUT_CELLS) ** (1.0 / 3.0))
    return float(cell) if np.isfinite(cell) and cell > 0 else 1.0
