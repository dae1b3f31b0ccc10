"""Neighbourhoods (SPEC 2): one query at the largest scale, sorted by distance, in blocks.

Every scale of a run is a prefix of the distance-sorted neighbour list of its largest scale,
so one k-d tree query per block of points serves them all.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

# A spherical query first asks for this many neighbours and only re-asks for max_neighbors
# for the points whose sphere holds more: airborne neighbourhoods at the paper's radii are
# mostly small, and a k-d tree query costs in proportion to k.
_FIRST_K = 64
# Bytes of neighbour lists (index + distance) held at once; bounds memory per block.
_BLOCK_BYTES = 96 * 2**20


@dataclass
class NeighborhoodBatch:
    """Neighbourhoods of a block of query points.

    Attributes
    ----------
    xyz : (N, 3) float64
        All coordinates of the cloud (centred), shared by every batch.
    rows : (B,) int64
        Indices of the query points x_i.
    idx : (B, K) int64
        Neighbour indices sorted by distance (x_i or a duplicate of it first); -1 pads.
    dist : (B, K) float64
        Distances matching ``idx``; inf pads.
    counts : (B, S) int64
        Number of neighbours within each scale, x_i included (a prefix length of ``idx``);
        0 where fewer than ``min_neighbors`` (undefined saliency).
    sigma : (B, S) float64
        Scale radius per point: the radius, or for k-nearest scales the distance to the k-th
        neighbour (used by tensor voting as the Gaussian decay).
    capped : (B,) bool
        Spherical neighbourhoods cut at ``max_neighbors`` nearest.
    """

    xyz: np.ndarray
    rows: np.ndarray
    idx: np.ndarray
    dist: np.ndarray
    counts: np.ndarray
    sigma: np.ndarray
    capped: np.ndarray


class NeighborIndex:
    """A k-d tree over a cloud that answers block queries at a set of resolved scales.

    Parameters
    ----------
    xyz : (N, 3) float64
        Coordinates, preferably centred (the tree and the kernels only see differences).
    kind : {"radius", "knn"}
    scales : (S,) array
        Radii in coordinate units, or k values; ascending.
    max_neighbors : int
        Cap of a spherical neighbourhood (nearest first), SPEC 2; default 512.
    min_neighbors : int
        A scale holding fewer neighbours (x_i included) gets count 0: undefined saliency.
    workers : int
        Threads for the k-d tree query (-1: all cores).
    """

    def __init__(self, xyz, kind, scales, *, max_neighbors=512, min_neighbors=3, workers=-1):
        self.xyz = xyz
        self.kind = kind
        self.scales = np.asarray(scales)
        self.max_neighbors = int(max_neighbors)
        self.min_neighbors = int(min_neighbors)
        self.workers = workers
        self.tree = cKDTree(xyz, balanced_tree=False, compact_nodes=False)
        n = len(xyz)
        self.k_max = int(min(self.scales.max(), n)) if kind == "knn" else min(self.max_neighbors, n)

    def block_size(self):
        """Query points per block so that one block's neighbour lists fit in _BLOCK_BYTES."""
        return max(1024, _BLOCK_BYTES // (16 * self.k_max))

    def blocks(self, rows=None):
        """Split ``rows`` (default: all points) into consecutive blocks of query indices."""
        rows = np.arange(len(self.xyz)) if rows is None else np.asarray(rows)
        step = self.block_size()
        return [rows[s:s + step] for s in range(0, len(rows), step)]

    def query(self, rows):
        """Neighbourhoods of the points ``rows`` at every scale, as a NeighborhoodBatch."""
        rows = np.asarray(rows, dtype=np.int64)
        q = self.xyz[rows]
        if self.kind == "knn":
            dist, idx = self.tree.query(q, k=self.k_max, workers=self.workers)
            dist, idx = _as_2d(dist, idx)
            counts = np.minimum(self.scales[None, :], np.isfinite(dist).sum(1)[:, None])
            sigma = np.take_along_axis(dist, np.maximum(counts - 1, 0), axis=1)
            capped = np.zeros(len(rows), bool)
        else:
            dist, idx, capped = self._query_radius(q)
            counts = np.stack([(dist <= r).sum(1) for r in self.scales], axis=1)
            sigma = np.broadcast_to(self.scales[None, :], counts.shape)
        idx = np.where(np.isfinite(dist), idx, -1)
        counts = np.where(counts >= self.min_neighbors, counts, 0)
        return NeighborhoodBatch(self.xyz, rows, idx, dist, counts.astype(np.int64),
                                 np.ascontiguousarray(sigma, dtype=np.float64), capped)

    def _query_radius(self, q):
        # cKDTree keeps distances strictly below the bound: nudge it so that d <= r_max counts.
        bound = np.nextafter(float(self.scales.max()), np.inf)
        k0 = min(_FIRST_K, self.k_max)
        dist, idx = _as_2d(*self.tree.query(q, k=k0, distance_upper_bound=bound, workers=self.workers))
        full = np.isfinite(dist[:, -1])
        # A neighbourhood is capped when the max_neighbors-th neighbour is still inside r_max.
        capped = full if k0 == self.max_neighbors else np.zeros(len(q), bool)
        if full.any() and self.k_max > k0:
            d2, i2 = _as_2d(*self.tree.query(q[full], k=self.k_max, distance_upper_bound=bound,
                                              workers=self.workers))
            width = int(np.isfinite(d2).sum(1).max())
            pad_d = np.full((len(q), width), np.inf)
            pad_i = np.full((len(q), width), len(self.xyz), dtype=np.int64)
            pad_d[:, :k0], pad_i[:, :k0] = dist, idx
            pad_d[full], pad_i[full] = d2[:, :width], i2[:, :width]
            dist, idx = pad_d, pad_i
            if self.k_max == self.max_neighbors:
                capped[full] = np.isfinite(d2[:, -1])
        else:
            width = max(1, int(np.isfinite(dist).sum(1).max()))
            dist, idx = dist[:, :width], idx[:, :width]
        return dist, idx, capped


def _as_2d(dist, idx):
    # cKDTree squeezes the last axis when k == 1.
    if dist.ndim == 1:
        dist, idx = dist[:, None], idx[:, None]
    return dist, idx.astype(np.int64)
