"""A tile's footprint in plan view: the convex hull of its points, its area, and which tiles'
footprints touch or lie within a distance of each other (spatial neighbours).

Coordinates are the tile's own, in its CRS's units; areas and distances in those units
squared and units (the callers convert with the metres per unit of the CRS).
"""
from __future__ import annotations

import numpy as np

from ..numerics.bounds import bounds


def convex_hull(xy):
    """(K, 2) vertices of the convex hull of plan-view points ``xy`` (N, 2), counter-clockwise,
    not closed. Points on a line (or fewer than three distinct) give their bounding rectangle,
    which may be flat."""
    from scipy.spatial import ConvexHull, QhullError

    xy = np.asarray(xy, dtype=np.float64)
    lo, hi = bounds(xy)
    try:
        hull = ConvexHull(xy)
        return xy[hull.vertices]  # counter-clockwise for 2-D input
    except (QhullError, ValueError):
        return np.array([[lo[0], lo[1]], [hi[0], lo[1]], [hi[0], hi[1]], [lo[0], hi[1]]])


def hull_of_hulls(hulls):
    """The convex hull of several point sets given by their own hulls (a file read in chunks)."""
    return convex_hull(np.concatenate([np.asarray(h, np.float64) for h in hulls]))


def polygon_area(polygon):
    """Area of a simple polygon (K, 2) by the shoelace formula, in squared coordinate units."""
    x, y = np.asarray(polygon, np.float64).T
    return float(abs(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1))) / 2.0)


class _Polygon:
    """A convex polygon with what distances to it need, computed once: its vertices, edges
    (start, vector, squared length) and unit edge normals."""

    def __init__(self, vertices):
        self.v = np.asarray(vertices, np.float64).reshape(-1, 2)
        self.edges = np.concatenate([self.v[1:], self.v[:1]]) - self.v
        self.length2 = np.maximum((self.edges ** 2).sum(axis=1), 1e-300)
        normals = np.column_stack([self.edges[:, 1], -self.edges[:, 0]])
        norm = np.hypot(normals[:, 0], normals[:, 1])
        self.normals = normals[norm > 0] / norm[norm > 0, None]

    def distances_from(self, points):
        """(P,) distance from each point to the polygon's nearest edge."""
        ap = points[:, None, :] - self.v[None, :, :]  # (P, E, 2)
        t = np.clip((ap * self.edges[None]).sum(axis=2) / self.length2[None], 0.0, 1.0)
        gap = ap - t[..., None] * self.edges[None]
        return np.sqrt((gap ** 2).sum(axis=2)).min(axis=1)


def _separation(p, q):
    """Largest gap between the projections of convex polygons ``p`` and ``q`` on their edge
    normals: positive when they are apart (a lower bound of their distance), else they meet."""
    gap = -np.inf
    for normals in (p.normals, q.normals):
        if len(normals):
            sp, sq = p.v @ normals.T, q.v @ normals.T  # (K, A) projections
            gap = max(gap, float(np.max(np.maximum(sq.min(axis=0) - sp.max(axis=0), sp.min(axis=0) - sq.max(axis=0)))))
    return gap


def polygon_distance(p, q):
    """Distance between two convex polygons (0 when they touch or overlap), in coordinate
    units."""
    p = p if isinstance(p, _Polygon) else _Polygon(p)
    q = q if isinstance(q, _Polygon) else _Polygon(q)
    if _separation(p, q) <= 0:
        return 0.0
    return float(min(q.distances_from(p.v).min(), p.distances_from(q.v).min()))


def neighbours(hulls, bounds, reach):
    """Spatial neighbours: for each footprint, the indices of the others whose convex hulls lie
    within ``reach`` of it (touching or overlapping ones included). ``hulls`` (K_i, 2) polygons
    and ``bounds`` (N, 4) x0, y0, x1, y1 in one CRS, ``reach`` in its units. Bounding boxes
    screen the pairs first."""
    bounds = np.asarray(bounds, np.float64).reshape(-1, 4)
    n = len(bounds)
    gap_x = np.maximum(bounds[None, :, 0] - bounds[:, None, 2], bounds[:, None, 0] - bounds[None, :, 2])
    gap_y = np.maximum(bounds[None, :, 1] - bounds[:, None, 3], bounds[:, None, 1] - bounds[None, :, 3])
    near = np.hypot(np.maximum(gap_x, 0), np.maximum(gap_y, 0)) <= reach
    out = [[] for _ in range(n)]
    polygons = {}
    for i, j in zip(*np.nonzero(np.triu(near, 1))):
        for k in (i, j):
            if k not in polygons:
                polygons[k] = _Polygon(hulls[k])
        if polygon_distance(polygons[i], polygons[j]) <= reach:
            out[i].append(int(j))
            out[j].append(int(i))
    return [np.array(sorted(v), dtype=np.int64) for v in out]
