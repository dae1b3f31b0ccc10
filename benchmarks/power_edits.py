"""Five kinds of known change made to a block of real survey tiles, for the change map's power
benchmark (benchmarks/change_power.py, issue 33). Each edit lies inside one 25 m cell of the
grid aligned to multiples of 25 m, 1 m inside its edges:

- **building removed**: the class-6 points of the largest building footprint inside the cell
  (benchmarks/edited_epoch.py finds the footprints);
- **building added**: a box building, 14 x 10 m, 8 m high, at the cell's density, sparse walls,
  the ground under it removed (benchmarks/edited_epoch.py);
- **trees cut**: the vegetation points 2 m or more above the ground of the cell with the most
  of them (vegetation: class 5 in IGN LiDAR HD, 1 in AHN3, which keeps vegetation there);
- **ground works**: earth moved, the ground points only: a pit and a heap beside it, each a disc
  of 5 m radius, 1 to 3 m deep and high at the centre (a paraboloid), in the most open cell;
- **new vegetation**: five trees planted on open ground, crowns of 2.5 to 4 m radius between 2-4
  m and 7-12 m above the ground, sampled at the cell's density (all in the vegetation class),
  half the ground points under the crowns hidden.

Each edited pair uses other cells (``rank``: the rank-th best cell of each kind), so that the
pairs of one block test different places.
"""
from __future__ import annotations

import numpy as np

from edited_epoch import BUILDING, CELL, GROUND, MARGIN, _box_building, _building_footprint, _cells, _inner

EDITS = ("building removed", "building added", "trees cut", "ground works", "new vegetation")
#: Vegetation this high above the ground (m) is a tree.
TREE = 2.0
PIT = 5.0  # radius of the pit and of the heap, metres
DEPTH = (1.0, 3.0)  # depth of the pit and height of the heap, metres
TREES = 5
CROWN_RADIUS, CROWN_BASE, CROWN_TOP = (2.5, 4.0), (2.0, 4.0), (7.0, 12.0)


def _ground_level(xyz, labels, pixel=2.0):
    """(N,) the ground's z under each point: the lowest ground point of its 2 m pixel, or of
    the nearest pixel holding ground points."""
    from scipy import ndimage

    lo = xyz[:, :2].min(axis=0)
    ij = np.floor((xyz[:, :2] - lo) / pixel).astype(np.int64)
    shape = tuple(ij.max(axis=0) + 1)
    level = np.full(shape, np.inf)
    g = labels == GROUND
    np.minimum.at(level, (ij[g, 0], ij[g, 1]), xyz[g, 2])
    empty = ~np.isfinite(level)
    if empty.any():  # each empty pixel takes the nearest pixel's level
        _, (ni, nj) = ndimage.distance_transform_edt(empty, return_indices=True)
        level = level[ni, nj]
    return level[ij[:, 0], ij[:, 1]]


def _full_cells(cells):
    """{(i, j): points} of the cells holding more than half the median cell's points."""
    keys, n = np.unique(cells, axis=0, return_counts=True)
    return {tuple(map(int, k)): int(c) for k, c in zip(keys, n) if c > 0.5 * np.median(n)}


def edit_block(xyz, labels, *, vegetation, rank=0, seed=0):
    """(xyz, labels, edits) of the edited block: the five edits of the module's docstring, each
    in its own cell (the ``rank``-th best of its kind not used by an earlier edit), and
    {edit: (i, j) of its 25 m cell}."""
    rng = np.random.default_rng([seed, rank])
    cells = _cells(xyz[:, :2])
    full = _full_cells(cells)
    ground_z = _ground_level(xyz, labels)
    used, edits = set(), {}

    def pick(scores):
        ordered = [c for _, c in sorted(((-s, c) for c, s in scores.items() if c in full))
                   if c not in used]
        chosen = ordered[min(rank, len(ordered) - 1)]
        used.add(chosen)
        return chosen

    def share(mask):
        counts = {}
        for key, n in zip(*np.unique(cells[mask], axis=0, return_counts=True)):
            counts[tuple(map(int, key))] = n
        return {c: counts.get(c, 0) / n for c, n in full.items()}

    def count(mask):
        return {c: v * full[c] for c, v in share(mask).items()}

    # building removed: footprints by size, the rank-th outside the used cells
    remove = np.zeros(len(xyz), bool)
    avoid = set()
    for _ in range(rank + 1):
        mask, cell = _building_footprint(xyz, labels, avoid | used)
        avoid.add(cell)
    used.add(cell)
    edits["building removed"] = cell
    remove |= mask
    # trees cut: the most tree points
    trees = (labels == vegetation) & (xyz[:, 2] - ground_z > TREE)
    cell = pick(count(trees))
    edits["trees cut"] = cell
    remove |= trees & _inner(xyz[:, :2], cell)
    open_ground = share(labels == GROUND)
    # building added, ground works, new vegetation: the most open cells
    cell = pick(open_ground)
    edits["building added"] = cell
    added, added_labels, hidden = _box_building(xyz, labels, cell, rng)
    remove |= hidden & (labels == GROUND)
    new_xyz, new_labels = [added], [added_labels]
    cell = pick(open_ground)
    edits["ground works"] = cell
    xyz = xyz.copy()
    x0, y0 = np.asarray(cell) * CELL
    for (cx, cy), sign in (((x0 + 7.5, y0 + 12.5), -1.0), ((x0 + 17.5, y0 + 12.5), 1.0)):
        depth = rng.uniform(*DEPTH)
        r2 = ((xyz[:, 0] - cx) ** 2 + (xyz[:, 1] - cy) ** 2) / PIT ** 2
        moved = (labels == GROUND) & (r2 < 1.0)
        xyz[moved, 2] += sign * depth * (1.0 - r2[moved])
    cell = pick(open_ground)
    edits["new vegetation"] = cell
    planted, under = _trees(xyz, labels, cell, ground_z, rng)
    remove |= under
    new_xyz.append(planted)
    new_labels.append(np.full(len(planted), vegetation, np.int64))
    keep = ~remove
    return (np.vstack([xyz[keep]] + new_xyz), np.concatenate([labels[keep]] + new_labels), edits)


def _trees(xyz, labels, cell, ground_z, rng):
    """Points of :data:`TREES` trees planted in ``cell`` and the mask of half the ground points
    under their crowns (hidden by them)."""
    in_cell = np.all(_cells(xyz[:, :2]) == cell, axis=1)
    density = in_cell.sum() / CELL ** 2
    base = float(np.median(ground_z[in_cell]))
    points, under = [], np.zeros(len(xyz), bool)
    lo = np.asarray(cell) * CELL + MARGIN
    for _ in range(TREES):
        r = rng.uniform(*CROWN_RADIUS)
        cx, cy = rng.uniform(lo + r, lo + CELL - 2 * MARGIN - r)
        bottom, top = base + rng.uniform(*CROWN_BASE), base + rng.uniform(*CROWN_TOP)
        n = rng.poisson(density * np.pi * r ** 2)
        # returns spread through the crown, more of them near its top (an ellipsoid's upper half)
        theta, u = rng.uniform(0, 2 * np.pi, n), np.sqrt(rng.uniform(0, 1, n))
        depth = rng.uniform(0, 1, n) ** 2
        x, y = cx + r * u * np.cos(theta), cy + r * u * np.sin(theta)
        z = bottom + (top - bottom) * np.sqrt(np.maximum(1 - u ** 2, 0)) * (1 - 0.8 * depth)
        points.append(np.column_stack([x, y, z]))
        below = (labels == GROUND) & ((xyz[:, 0] - cx) ** 2 + (xyz[:, 1] - cy) ** 2 < r ** 2)
        under |= below & (rng.random(len(xyz)) < 0.5)
    return np.vstack(points), under
