"""Tiles with halos: each tile's core points get exactly the saliency of the whole-set run.

A set of points is cut in plan view into square processing tiles. A tile is computed on its
core points plus a halo: the points within a margin of the tile. What a point's saliency
depends on must lie inside that block, and is checked per point rather than trusted:

- its neighbourhood: every point within its largest scale (a radius, or the distance to its
  k-th neighbour, ties included) must be in the block, so that distance must be shorter than
  the point's distance to the halo's edge;
- its neighbours' area weights (:mod:`lidar_sig.numerics.neighbors`): each neighbour's distance to its
  second-nearest other point (capped) must be shorter than that neighbour's distance to the
  edge, unless those distances are the whole set's already (a set's run of up to CAP_POINTS
  points finds them in a first pass, :func:`tile_second_distances`, checked the same way, and
  every tile takes them; above, the first pass searches only the cap's sample,
  :func:`tile_cap_sample`, and each tile its own points).

A core point that fails either test is recomputed with a halo twice as wide, until it passes
or the block holds the whole set. Sides of the halo beyond the set's extent are not edges.
What depends on the whole set is decided once and shared by every tile (:class:`SetContext`):
the centre the coordinates are taken from, the scales in metres (normalized radii follow the
set's extent), and the area-weight cap (from the median second-neighbour distance of all
distinct locations, or of a sample of windows above a million points,
:data:`~lidar_sig.numerics.neighbors.CAP_POINTS`: the tiles then find their points' distances
themselves, with the cap in their halo). Exact duplicate points share their x, y and so their tile, and are merged
there as in the single-block run.

The voxel grid of a block differs from the whole set's, so points tied at exactly the same
distance from a query can be listed in another order: a covariance then sums the same terms
in another order, and the last bits can differ (about 1e-16 relative). Everything else is the
same computation on the same numbers.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..numerics.bounds import bounds
from ..base.errors import LidarSigError, arg, positive_metres
from ..numerics.neighbors import (CAP_REACH, NeighborIndex, ScaleKind, area_cap, cap_share, in_cap_windows, radius_reach,
                                  sampled_area_cap, unique_points)

#: Relative margin kept between a needed distance and the halo's edge (round-off of the tests).
MARGIN = 1e-9
#: The second-neighbour search of the area-weight cap runs on a voxel grid sized for this many
#: neighbours: larger voxels than 3 neighbours would give leave fewer queries to the k-d tree
#: and took a third of the time on generated airborne scenes.
SECOND_GRID_K = 64
#: A tile's k-nearest queries may grow 12 voxel shells (one block's 6), then 24 when few are
#: left (neighbors._FARTHER_VOXELS), before going to a scan or the k-d tree: the few isolated
#: points of a tile (3 of 1.8 million in a generated airborne tile) otherwise cost a tree of
#: the whole block, a large share of the cap pass's search (docs/performance.md). The neighbours are
#: the same; a distance found by the tree can differ in its last bit (it is squared back from
#: the tree's), as it already could where a block and the whole cloud sent a query different
#: ways. Such points lie farther than the area-weight cap, so their weight is the cap either way.
TILE_SHELLS = 12


@dataclass(frozen=True)
class SetContext:
    """What every tile of a set shares so that its results equal the single-block run's.

    Attributes
    ----------
    centre : (3,) tuple
        Bounding-box centre of the set, in the files' coordinate units; coordinates are taken
        from it exactly as :meth:`PointCloud.metric_xyz` does for one cloud.
    factors : (3,) tuple
        Metres per coordinate unit.
    lo, hi : (2,) tuples
        Plan-view extent of the set in those centred metric coordinates (metres).
    scales : tuple
        Resolved scales: k values, or radii in metres.
    area_cap : float or None
        Cap of the second-neighbour distance of area weights, metres; None without area weights.
    density : float
        Points per square metre of the set (sizes the first halo).
    """

    centre: tuple
    factors: tuple
    lo: tuple
    hi: tuple
    scales: tuple
    area_cap: float | None = None
    density: float = 1.0

    def plan_view(self, x, y):
        """(x, y) in the files' units -> centred metres, ``(c - centre) * factors`` (as for one
        cloud; a tile's load converts its points the same way, :mod:`lidar_sig.tiling._load`)."""
        return ((np.asarray(x, dtype=np.float64) - self.centre[0]) * self.factors[0],
                (np.asarray(y, dtype=np.float64) - self.centre[1]) * self.factors[1])

    def key(self):
        """Text that changes whenever a tile's results would: for resuming safely."""
        return repr((self.centre, self.factors, self.lo, self.hi, self.scales, self.area_cap))


@dataclass(frozen=True)
class Tiling:
    """Square processing tiles of side ``size`` metres over the plan-view extent ``lo``-``hi``
    (centred metric coordinates); tile (i, j) spans x in [lo_x + i size, lo_x + (i+1) size)."""

    lo: tuple
    hi: tuple
    size: float

    def __post_init__(self):
        check_tile_size(self.size)

    @property
    def shape(self):
        """Tiles along x and y."""
        return tuple(max(1, math.ceil((h - l) / self.size)) for l, h in zip(self.lo, self.hi))

    def index(self, xy):
        """(N, 2) int tile index (i, j) of plan-view points ``xy`` (metres, centred)."""
        xy = np.asarray(xy)
        return np.column_stack([self._along(xy[:, 0], 0), self._along(xy[:, 1], 1)])

    def core(self, x, y, ij):
        """(N,) bool: the plan-view points (``x``, ``y``) (metres, centred) whose tile is ``ij``
        (:meth:`index`, column by column: ``np.all(index == ij, axis=1)`` took five times as long)."""
        return (self._along(x, 0) == ij[0]) & (self._along(y, 1) == ij[1])

    def _along(self, v, axis):
        """The tiles' index along ``axis`` (0: x, 1: y) of coordinates ``v`` (metres, centred)."""
        # float64 whatever the dtypes of v and lo: in float32, survey coordinates (10^5 to 10^6 m)
        # round to centimetres or more, and a point near a tile's edge changes tile
        k = np.floor((np.asarray(v) - np.float64(self.lo[axis])) / self.size).astype(np.int64)
        return np.clip(k, 0, self.shape[axis] - 1)

    def box(self, i, j):
        """(x0, y0, x1, y1) of tile (i, j), metres; the last row and column reach the extent."""
        nx, ny = self.shape
        x0, y0 = self.lo[0] + i * self.size, self.lo[1] + j * self.size
        x1 = self.hi[0] if i == nx - 1 else x0 + self.size
        y1 = self.hi[1] if j == ny - 1 else y0 + self.size
        return (x0, y0, x1, y1)

    def tiles(self):
        """Every (i, j), row by row."""
        nx, ny = self.shape
        return [(i, j) for j in range(ny) for i in range(nx)]


def check_tile_size(size):
    """The tile side as a float of metres, or LidarSigError naming the value."""
    return positive_metres(size, "the tile size")


def tile_name(i, j):
    """Name of processing tile (i, j) in messages and file names."""
    return f"tile_{i}_{j}"


@dataclass(frozen=True)
class Halo:
    """A tile's box grown by ``width`` metres; sides beyond the set's extent are open."""

    box: tuple
    width: float
    lo: tuple
    hi: tuple

    @property
    def bounds(self):
        """(x0, y0, x1, y1) of the block to load, metres."""
        x0, y0, x1, y1 = self.box
        w = self.width
        return (x0 - w, y0 - w, x1 + w, y1 + w)

    @property
    def whole(self):
        """True when the block holds the whole set."""
        x0, y0, x1, y1 = self.bounds
        return x0 < self.lo[0] and y0 < self.lo[1] and x1 > self.hi[0] and y1 > self.hi[1]

    def edge_distance(self, xyz):
        """(N,) plan-view distance from each point to the nearest edge of the block (inf where
        no side is an edge). Any point outside the block is at least this far in 3D."""
        x0, y0, x1, y1 = self.bounds
        x, y = xyz[:, 0], xyz[:, 1]
        d = np.full(len(xyz), np.inf)
        for closed, gap in ((x0 >= self.lo[0], x - x0), (y0 >= self.lo[1], y - y0),
                            (x1 <= self.hi[0], x1 - x), (y1 <= self.hi[1], y1 - y)):
            if closed:
                d = np.minimum(d, gap)
        return d


@dataclass
class TileResult:
    """Saliency of a tile's core points: ``ids`` (the loader's point identifiers), ``values``
    (N, 3), ``chosen`` (N,) scale index or None, and counts for the run statistics."""

    ids: np.ndarray
    values: np.ndarray
    chosen: np.ndarray | None
    stats: dict = field(default_factory=dict)


def check_tileable(pipeline):
    """Refuse a descriptor that cannot run in tiles (``Descriptor.tileable``: one that needs a
    pass over the whole cloud before the blocks)."""
    if not pipeline.descriptor.tileable:
        raise LidarSigError(f"the {pipeline.descriptor.name} descriptor needs the whole cloud at once "
                            "(its prepare step) and cannot run in tiles; process each file alone, without "
                            f"{arg('tile_size')}, {arg('workers')} or {arg('scheduler')}")


def first_halo(pipeline, ctx, *, weights_known=False):
    """A halo width (metres) that usually suffices: the largest radius, or four times the
    expected k-th neighbour distance at the set's density (twice left about 40 of 2.5 million
    points of a generated airborne tile, in tree crowns, to be recomputed in blocks of their
    own, at a cost docs/performance.md gives), plus the area-weight cap unless the neighbours' weights are
    known already (``weights_known``: they need no second neighbour inside)."""
    if pipeline.scales.by_count:
        reach = 4.0 * math.sqrt(max(ctx.scales) / (math.pi * ctx.density))
    else:
        reach = radius_reach(max(ctx.scales) * (1.0 + MARGIN))
    return reach + (0.0 if weights_known else ctx.area_cap or 0.0)


def block_saliency(pipeline, xyz, query, edge, scales, area_cap, second=None):
    """Saliency of the block points ``query`` (bool mask) computed on the block ``xyz`` (centred
    metres) at the set's resolved ``scales``, and whether each is certainly that of the whole
    set (``edge``: each point's distance to the block's edge, metres). ``second``: each block
    point's second-neighbour distance in the whole set, when known (the weights are then the
    set's, and need no check against the edge).

    Returns ``(location, values, chosen, ok, capped)``: ``location`` (M,) the distinct
    location of every block point; ``values`` (L, 3), ``chosen`` (L,) or None, ``ok`` (L,) and
    ``capped`` (L,: the spherical neighbourhood was cut at max_neighbors) per location
    (meaningful where queried).
    """
    support, inverse = unique_points(xyz)
    location = np.arange(len(xyz)) if inverse is None else inverse
    m = len(support)
    edge_loc = np.empty(m)
    edge_loc[location] = edge
    queried = np.zeros(m, bool)
    queried[location[query]] = True
    scales = np.asarray(scales)
    second_loc = None
    by_area = pipeline.weights.by_area
    if second is not None and by_area:  # copies of a location share its distance
        second_loc = np.empty(m)
        second_loc[location] = second
    index = NeighborIndex(support, pipeline.scales.kind, scales, max_neighbors=pipeline.max_neighbors,
                          min_neighbors=pipeline.min_neighbors, weights=pipeline.weights, area_cap=area_cap,
                          second=second_loc, shells=TILE_SHELLS)
    edge_sorted = edge_loc[index.order]
    if second_loc is not None:  # the set's own distances: every weight is the set's
        weight_ok = np.ones(m, bool)
    elif by_area and m < 3:  # no second neighbour inside: only a whole set is sure
        weight_ok = np.isinf(edge_sorted)
    elif by_area:  # sqrt(weight) is the capped second-neighbour distance
        weight_ok = np.sqrt(index.weights) * (1.0 + MARGIN) < edge_sorted
    else:
        weight_ok = np.ones(m, bool)
    # an unsure weight belongs to a point near the block's edge (at most ``worst`` from it), and
    # the edge distance changes by at most the distance moved: only a query whose neighbourhood
    # reaches within ``worst`` of the edge can hold one (1e-6 m covers the round-off)
    worst = float(edge_sorted[~weight_ok].max()) if not weight_ok.all() else -np.inf
    values = np.full((m, 3), np.nan)
    chosen = None
    ok = np.zeros(m, bool)
    capped = np.zeros(m, bool)
    rows = index.rows_of(np.flatnonzero(queried))
    for part in index.blocks(rows):
        batch = index.query(part)
        combined, pick = pipeline.describe(batch)
        loc = batch.ids
        values[loc] = combined
        if pick is not None:
            if chosen is None:
                chosen = np.full(m, -1, np.int64)
            chosen[loc] = pick
        capped[loc] = batch.capped
        n = batch.n
        if pipeline.scales.by_count:
            enough = (n >= max(scales)) | np.isinf(edge_sorted[part])
        else:
            enough = True
        reach = batch.reach()
        inside = reach * (1.0 + MARGIN) < edge_sorted[part]
        neighbours_ok = np.ones(len(part), bool)
        near = np.flatnonzero(edge_sorted[part] - reach * (1.0 + MARGIN) <= worst + 1e-6)
        if len(near):
            used = np.arange(batch.idx.shape[1])[None, :] < n[near, None]
            neighbours_ok[near] = np.all(~used | weight_ok[np.where(used, batch.idx[near], 0)], axis=1)
        ok[loc] = enough & inside & neighbours_ok
    return location, values, chosen, ok, capped


def tile_saliency(pipeline, load, tiling, ij, ctx, *, halo=None, second_of=None, sampled=None):
    """Saliency of the core points of processing tile ``ij`` (see the module docstring).

    ``load(bounds) -> (xyz, ids)`` returns the set's points within plan-view bounds (x0, y0,
    x1, y1) in centred metres, with identifiers; core points are those ``tiling`` puts in
    ``ij``. ``second_of(xyz, ids)``, when given, returns the points' second-neighbour distances
    in the whole set (:func:`tile_second_distances` of every tile), so that no block searches
    them again. ``sampled()``, when given, returns the (N,) bool mask of the points of the first
    load whose saliency is asked for (a sample; None: all): the others are listed, undefined.
    Returns a :class:`TileResult` in the order of the first load.
    """
    check_tileable(pipeline)
    box = tiling.box(*ij)
    width = first_halo(pipeline, ctx, weights_known=second_of is not None) if halo is None else float(halo)
    xyz, ids = load(Halo(box, width, ctx.lo, ctx.hi).bounds)
    core = tiling.core(xyz[:, 0], xyz[:, 1], ij)
    out_ids = ids[core]
    values = np.full((len(out_ids), 3), np.nan)
    chosen = None
    capped = np.zeros(len(out_ids), bool)
    asked = None if sampled is None else sampled()
    first_want = core if asked is None else core & asked
    if not first_want.any():
        return TileResult(out_ids, values, None, {"n_points": len(out_ids), "n_locations": 0, "n_capped": 0,
                                                  "n_recomputed": 0, "halo": width,
                                                  **({} if asked is None else {"n_sampled": 0})})
    core_location = None  # distinct location of each core point asked for, from the first block
    by_id = None  # out_ids' order, sorted once for the blocks of recomputed points
    n_recomputed = 0
    widest = width
    # blocks still to compute: (box, halo width, positions in out_ids); the tile first
    first_pos = np.flatnonzero(first_want[core])
    pending = [(box, width, first_pos)]
    while pending:
        box, width, todo = pending.pop()
        halo_ = Halo(box, width, ctx.lo, ctx.hi)
        if core_location is None:  # the tile's own block, loaded already: its core points in order
            want, pos = first_want, todo
        else:  # map the block's wanted points back to positions in out_ids
            xyz, ids = load(halo_.bounds)
            want = np.isin(ids, out_ids[todo])
            if by_id is None:
                by_id = np.argsort(out_ids, kind="stable")
            pos = by_id[np.searchsorted(out_ids[by_id], ids[want])]
        second = None if second_of is None else second_of(xyz, ids)
        location, vals, pick, ok, cut = block_saliency(pipeline, xyz, want, halo_.edge_distance(xyz),
                                                       ctx.scales, ctx.area_cap, second)
        loc = location[want]
        if core_location is None:
            core_location = loc
        values[pos] = vals[loc]
        capped[pos] = cut[loc]
        if pick is not None:
            if chosen is None:
                chosen = np.full(len(out_ids), -1, np.int64)
            chosen[pos] = pick[loc]
        failed = ~(ok[loc] | halo_.whole)
        if failed.any():
            n_recomputed += int(failed.sum())
            widest = max(widest, 2.0 * width)
            pending += _regroup(xyz[want][failed], pos[failed], 2.0 * width)
    per_location = np.bincount(core_location)  # counting, not sorting: a tile holds millions
    stats = {"n_points": len(out_ids), "n_locations": int(np.count_nonzero(per_location)),
             "n_capped": int(np.count_nonzero(np.bincount(core_location[capped[first_pos]], minlength=1))),
             "n_recomputed": n_recomputed, "halo": widest,
             **({} if asked is None else {"n_sampled": len(first_pos)})}
    return TileResult(out_ids, values, chosen, stats)


def _regroup(xyz, positions, width):
    """Blocks for points to recompute with halo ``width``: points near each other share one
    (plan-view cells of 8 halo widths), so that a few scattered failures do not each reload
    a tile-sized block. Returns [(box, width, positions)]."""
    cell = np.floor(xyz[:, :2] / (8.0 * width)).astype(np.int64)
    _, group = np.unique(cell, axis=0, return_inverse=True)
    out = []
    for g in range(group.max() + 1):
        mine = group.ravel() == g
        lo, hi = bounds(xyz[mine, :2])
        out.append(((*lo.tolist(), *hi.tolist()), width, positions[mine]))
    return out


def tile_second_distances(load, tiling, ij, ctx, *, halo=None):
    """Second-neighbour distance (metres) of each distinct location among tile ``ij``'s core
    points, checked against the halo like the saliency (for the set's area-weight cap); a
    location that fails is computed again with a halo twice as wide, near others that fail
    (as for the saliency).

    Returns ``(ids, point_d, location_d)``: the core points' identifiers and each one's
    distance (copies of a location share it), and the distance of each distinct location once
    (what the set's median is taken over).
    """
    box = tiling.box(*ij)
    # ten times the mean spacing: a second neighbour farther than that is rare (isolated points)
    width = 10.0 * math.sqrt(1.0 / (math.pi * ctx.density)) if halo is None else float(halo)
    xyz, ids = load(Halo(box, width, ctx.lo, ctx.hi).bounds)
    core = np.flatnonzero(tiling.core(xyz[:, 0], xyz[:, 1], ij))
    if not len(core):
        return ids[core], np.empty(0), np.empty(0)
    support, inverse = unique_points(xyz)
    point_ids = ids[core]
    if inverse is None:
        loc, per_point = core, None
    else:  # one point per core location
        loc, first, per_point = np.unique(inverse[core], return_index=True, return_inverse=True)
        core = core[first]
    want_ids = ids[core]
    out = np.full(len(want_ids), np.nan)
    pending = [(box, width, np.arange(len(want_ids)))]
    loaded = True  # the tile's own block, the first of pending
    while pending:
        box, width, todo = pending.pop()
        halo_ = Halo(box, width, ctx.lo, ctx.hi)
        if not loaded:
            xyz, ids = load(halo_.bounds)
            support, inverse = unique_points(xyz)
            at = positions_of(ids, want_ids[todo])
            loc = at if inverse is None else inverse[at]
        loaded = False
        good = np.zeros(len(todo), bool)
        if halo_.whole or len(support) >= 3:  # fewer: the second neighbour is outside
            # a grid sized for SECOND_GRID_K neighbours: the 3-nearest search is fastest on it
            index = NeighborIndex(support, ScaleKind.KNN, np.array([min(SECOND_GRID_K, len(support))]), min_neighbors=1)
            # queries in the grid's order: each bounds the next (lidar_sig.numerics._voxels)
            wanted = np.zeros(len(support), bool)
            wanted[loc] = True
            rows = np.flatnonzero(wanted[index.order])
            by_location = np.empty(len(support))
            by_location[index.order[rows]] = index.second_distances(rows, shells=TILE_SHELLS)
            d = by_location[loc]
            good = halo_.whole | (d * (1.0 + MARGIN) < halo_.edge_distance(support[loc]))
            out[todo[good]] = d[good]
        if not good.all():
            pending += _regroup(support[loc[~good]], todo[~good], 2.0 * width)
    return point_ids, out if per_point is None else out[per_point], out


def tile_cap_sample(load, tiling, ij, ctx, share):
    """Second-neighbour distances (metres) of the distinct locations among tile ``ij``'s core
    points that lie in the windows of the area-weight cap's sample of ``share``
    (:func:`~lidar_sig.numerics.neighbors.in_cap_windows`), exact up to CAP_REACH (beyond it, some
    distance beyond it: the cap takes none past it). ``load(bounds) -> (xyz, ids, labels, raw)``.
    Every point within CAP_REACH of such a location lies within CAP_REACH of its window and of
    the tile, so a block of those few points alone finds each distance."""
    x0, y0, x1, y1 = tiling.box(*ij)
    xyz, _, _, raw = load((x0 - CAP_REACH, y0 - CAP_REACH, x1 + CAP_REACH, y1 + CAP_REACH))
    xy = raw[:, :2] * np.asarray(ctx.factors[:2])
    near = in_cap_windows(xy, share, CAP_REACH)
    xyz, xy = xyz[near], xy[near]
    wanted = tiling.core(xyz[:, 0], xyz[:, 1], ij) & in_cap_windows(xy, share)
    if not wanted.any():
        return np.empty(0)
    support, inverse = unique_points(xyz)
    loc = np.flatnonzero(wanted) if inverse is None else np.unique(inverse[wanted])
    if len(support) < 3:  # fewer than two others within the reach: each distance is beyond it
        return np.full(len(loc), np.inf)
    index = NeighborIndex(support, ScaleKind.KNN, np.array([min(SECOND_GRID_K, len(support))]), min_neighbors=1)
    asked = np.zeros(len(support), bool)
    asked[loc] = True
    return index.second_distances(np.flatnonzero(asked[index.order]), shells=TILE_SHELLS)


def positions_of(sorted_source, wanted):
    """Positions in ``sorted_source`` (any order, unique) of the identifiers ``wanted``."""
    order = np.argsort(sorted_source, kind="stable")
    at = np.searchsorted(sorted_source[order], wanted)
    return order[at]


def context_of(xyz_raw_lo, xyz_raw_hi, factors, pipeline, n_points, *, area_cap_value=None):
    """The SetContext of a set with raw bounding box ``xyz_raw_lo``-``xyz_raw_hi`` (file units)."""
    lo = np.asarray(xyz_raw_lo, dtype=np.float64)
    hi = np.asarray(xyz_raw_hi, dtype=np.float64)
    centre = (lo + hi) / 2.0  # as PointCloud.metric_xyz
    f = np.asarray(factors, dtype=np.float64)
    mlo, mhi = (lo - centre) * f, (hi - centre) * f
    scales = _resolve(pipeline, mlo, mhi)
    area = max((mhi[0] - mlo[0]) * (mhi[1] - mlo[1]), 1e-12)
    return SetContext(tuple(centre.tolist()), tuple(f.tolist()), tuple(mlo[:2].tolist()),
                      tuple(mhi[:2].tolist()), tuple(scales), area_cap_value, max(n_points / area, 1e-9))


def _resolve(pipeline, mlo, mhi):
    # Scales.resolve needs points only for their bounding box: give it the two corners.
    return pipeline.scales.resolve(np.stack([mlo, mhi])).tolist()


def saliency_in_tiles(pipeline, cloud, tile_size, *, halo=None):
    """Per-point Saliency of an in-memory ``cloud`` computed tile by tile (``tile_size`` metres):
    the same as ``pipeline.saliency(cloud)``, one tile's block in memory at a time besides the
    cloud. Returns ``(saliency, stats)`` with the summed tile statistics, ``n_recomputed``
    among them (core points recomputed with a wider halo). Withheld and noise points are left
    out as ``pipeline.saliency`` leaves them out (``n_excluded``)."""
    from ..method.saliency_map import Saliency

    check_tileable(pipeline)
    kept = pipeline.kept(cloud)
    if kept is not None:  # the others as if absent, then undefined
        sal, totals = saliency_in_tiles(pipeline, cloud.subset(kept), tile_size, halo=halo)
        return Saliency.of_kept(sal.values, sal.optimal_scale, kept), {**totals, "n_excluded": int((~kept).sum())}
    xyz = cloud.metric_xyz()
    ctx = context_of(*bounds(cloud.xyz), cloud.units.factors, pipeline, len(cloud))
    tiling = Tiling(ctx.lo, ctx.hi, float(tile_size))
    ids = np.arange(len(xyz))

    def load(bounds):
        x0, y0, x1, y1 = bounds
        inside = (xyz[:, 0] >= x0) & (xyz[:, 0] <= x1) & (xyz[:, 1] >= y0) & (xyz[:, 1] <= y1)
        return xyz[inside], ids[inside]

    if pipeline.weights.by_area:
        share, cap = cap_share(len(cloud)), None
        if share < 1.0:
            def load_raw(bounds):
                xyz_, ids_ = load(bounds)
                return xyz_, ids_, None, cloud.xyz[ids_]

            cap = sampled_area_cap(np.concatenate([tile_cap_sample(load_raw, tiling, ij, ctx, share)
                                                   for ij in tiling.tiles()]))
        if cap is None:
            cap = area_cap(np.concatenate([tile_second_distances(load, tiling, ij, ctx)[2] for ij in tiling.tiles()]))
        ctx = SetContext(ctx.centre, ctx.factors, ctx.lo, ctx.hi, ctx.scales, cap, ctx.density)
    values = np.full((len(xyz), 3), np.nan)
    chosen = None
    totals = {}
    for ij in tiling.tiles():
        r = tile_saliency(pipeline, load, tiling, ij, ctx, halo=halo)
        values[r.ids] = r.values
        if r.chosen is not None:
            chosen = np.full(len(xyz), -1, np.int64) if chosen is None else chosen
            chosen[r.ids] = r.chosen
        for k in ("n_points", "n_locations", "n_capped", "n_recomputed"):
            totals[k] = totals.get(k, 0) + int(r.stats[k])
    totals["n_tiles"] = len(tiling.tiles())
    totals["n_excluded"] = 0
    return Saliency.from_values(values, chosen), totals
