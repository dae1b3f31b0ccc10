"""A second epoch of a block of tiles with known changes, for the change map (issues 13, 17).

Epoch 1 is a folder of tiles joined: by default the six IGN LiDAR HD tiles of Montpellier
(../shared/data/ign_lidarhd_montpellier); the two AHN3 crops of Delft work too (``--folder``,
``--vegetation 1``: AHN3 keeps vegetation in class 1). Epoch 2 is made from it by three edits,
each inside one 25 m cell of the grid aligned to multiples of 25 m, then everything is
resampled and moved:

1. a building removed: the class-6 points of the largest building footprint that lies wholly
   inside one cell (footprints are the connected parts of a 1 m raster of class-6 points);
2. the vegetation (class 5, high vegetation, by default) of another area removed: every point
   of that class in the cell with the most of them, 1 m inside its edges;
3. a synthetic box building added on open ground: a flat roof 14 m x 10 m, 8 m above the
   ground, sampled at the cell's own density (class 6), sparse walls, and the ground points
   under it removed (the roof hides them);
4. a uniform random 80% of the points kept and the whole cloud shifted by (0.3, -0.2, 0.05) m.

    python benchmarks/edited_epoch.py [--out DIR] [--folder DIR --vegetation CODE]
    # writes epoch1.laz and epoch2.laz

The function :func:`edited_epochs` returns both clouds in memory and the three edited cells.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
IGN = ROOT.parent / "shared" / "data" / "ign_lidarhd_montpellier"

CELL = 25.0
SHIFT = (0.3, -0.2, 0.05)
KEEP = 0.8
BOX = (14.0, 10.0, 8.0)  # length, width, height of the added building, metres
MARGIN = 1.0  # metres kept between an edit and its cell's edges
BUILDING, HIGH_VEGETATION, GROUND = 6, 5, 2


def _cells(xy):
    """(N, 2) integer (i, j) of the 25 m cell of each point (aligned to multiples of 25 m)."""
    return np.floor(xy / CELL).astype(np.int64)


def _building_footprint(xyz, labels, avoid=()):
    """Mask of the class-6 points of the largest building footprint inside one cell (not one of
    ``avoid``), and the cell.

    Roofs of this dense block touch each other across cells, so a footprint is a connected part
    of the 1 m raster of class-6 points once the bands within 1 m of the cell edges are cut out.
    """
    from scipy import ndimage

    b = labels == BUILDING
    xy = xyz[b, :2]
    lo = np.floor(xy.min(axis=0))
    ij = np.floor(xy - lo).astype(np.int64)
    raster = np.zeros(ij.max(axis=0) + 1, bool)
    raster[ij[:, 0], ij[:, 1]] = True
    for axis in (0, 1):  # cut the bands along the cell edges
        centres = lo[axis] + np.arange(raster.shape[axis]) + 0.5
        offset = np.mod(centres, CELL)
        band = (offset < MARGIN) | (offset > CELL - MARGIN)
        if axis == 0:
            raster[band, :] = False
        else:
            raster[:, band] = False
    parts, _ = ndimage.label(raster, structure=np.ones((3, 3)))
    part_of_point = parts[ij[:, 0], ij[:, 1]]
    sizes = np.bincount(part_of_point)
    sizes[0] = 0
    points = np.flatnonzero(b)
    for best in np.argsort(-sizes, kind="stable"):
        mask = np.zeros(len(xyz), bool)
        mask[points[part_of_point == best]] = True
        cell = tuple(int(v) for v in _cells(xyz[mask, :2])[0])
        if cell not in avoid:
            return mask, cell
    raise ValueError("no building footprint outside the cells to avoid")


def _inner(xy, cell):
    """Mask of points 1 m or more inside cell (i, j)."""
    lo = np.asarray(cell) * CELL + MARGIN
    hi = (np.asarray(cell) + 1) * CELL - MARGIN
    return np.all((xy >= lo) & (xy < hi), axis=1)


def _box_building(xyz, labels, cell, rng):
    """Points of a box building centred in ``cell`` and the mask of the ground points it hides."""
    length, width, height = BOX
    centre = (np.asarray(cell) + 0.5) * CELL
    in_cell = np.all(_cells(xyz[:, :2]) == cell, axis=1)
    density = in_cell.sum() / CELL ** 2  # points per m2 of this cell
    lo, hi = centre - (length / 2, width / 2), centre + (length / 2, width / 2)
    under = np.all((xyz[:, :2] >= lo) & (xyz[:, :2] < hi), axis=1)
    ground = under & (labels == GROUND)
    base = float(np.median(xyz[ground, 2])) if ground.any() else float(np.median(xyz[in_cell, 2]))
    n_roof = rng.poisson(density * length * width)
    roof = np.column_stack([rng.uniform(lo[0], hi[0], n_roof), rng.uniform(lo[1], hi[1], n_roof),
                            base + height + 0.02 * rng.standard_normal(n_roof)])
    walls = []
    for (x0, y0), (x1, y1) in (((lo[0], lo[1]), (hi[0], lo[1])), ((hi[0], lo[1]), (hi[0], hi[1])),
                               ((hi[0], hi[1]), (lo[0], hi[1])), ((lo[0], hi[1]), (lo[0], lo[1]))):
        side = np.hypot(x1 - x0, y1 - y0)
        m = rng.poisson(0.6 * side * height)  # a nadir scanner sees few wall points
        t = rng.uniform(0, 1, m)
        walls.append(np.column_stack([x0 + t * (x1 - x0), y0 + t * (y1 - y0), base + rng.uniform(0, height, m)]))
    added = np.vstack([roof, *walls])
    return added, np.full(len(added), BUILDING, np.int64), under


def edited_epochs(folder=IGN, *, seed=13, vegetation=HIGH_VEGETATION):
    """(epoch 1, epoch 2, edits): the two PointClouds and {edit name: (x, y) centre of its 25 m
    cell in epoch 1's coordinates}; ``vegetation`` is the class code of the vegetation removed
    (5 in IGN LiDAR HD, 1 in AHN3)."""
    from lidar_sig.change_map import read_epoch

    one = read_epoch(Path(folder))
    if Path(folder) == IGN:
        one.path = "IGN Montpellier, six tiles"
    two, edits = edit(one, seed=seed, vegetation=vegetation)
    return one, two, edits


def edit(one, *, seed=13, vegetation=HIGH_VEGETATION, avoid=(), name="edited epoch"):
    """(epoch 2, edits): the three edits of the module's docstring made to the PointCloud
    ``one`` in cells other than the (x, y) centres ``avoid``, then 80% of the points kept and
    everything moved; edits as {edit name: (x, y) centre of its 25 m cell in ``one``'s
    coordinates}."""
    from lidar_sig.method.cloud import PointCloud

    rng = np.random.default_rng(seed)
    xyz, labels = one.xyz, one.labels
    avoid = {tuple(int(v) for v in np.floor(np.asarray(c) / CELL)) for c in avoid}
    cells = _cells(xyz[:, :2])
    remove_building, building_cell = _building_footprint(xyz, labels, avoid)
    # the cell with the most vegetation, other than the building's
    veg = labels == vegetation
    keys, counts = np.unique(cells[veg], axis=0, return_counts=True)
    order = [tuple(map(int, keys[k])) for k in np.argsort(-counts, kind="stable")]
    veg_cell = next(c for c in order if c != building_cell and c not in avoid)
    remove_veg = veg & _inner(xyz[:, :2], veg_cell)
    # the open-ground cell: the largest share of ground among full cells, other than both
    keys, n_all = np.unique(cells, axis=0, return_counts=True)
    ground_share = [(np.sum(labels[np.all(cells == k, axis=1)] == GROUND) / n, tuple(map(int, k)))
                    for k, n in zip(keys, n_all) if n > 0.5 * np.median(n_all)]
    box_cell = next(c for _, c in sorted(ground_share, reverse=True)
                    if c not in (building_cell, veg_cell) and c not in avoid)
    added, added_labels, hidden = _box_building(xyz, labels, box_cell, rng)
    keep = ~(remove_building | remove_veg | (hidden & (labels == GROUND)))
    xyz2 = np.vstack([xyz[keep], added])
    labels2 = np.concatenate([labels[keep], added_labels])
    sample = rng.random(len(xyz2)) < KEEP
    xyz2 = xyz2[sample] + np.asarray(SHIFT)
    two = PointCloud(np.round(xyz2, 3), labels2[sample], path=name, crs=one.crs, units=one.units)
    edits = {"building removed": building_cell, "vegetation removed": veg_cell, "box building added": box_cell}
    return two, {k: tuple((np.asarray(c) + 0.5) * CELL) for k, c in edits.items()}


def write_las(cloud, path):
    """Write a PointCloud's coordinates and classes as LAS 1.4 (point format 6) with its CRS."""
    import laspy
    import pyproj

    header = laspy.LasHeader(point_format=6, version="1.4")
    header.offsets = np.floor(cloud.xyz.min(axis=0))
    header.scales = np.array([0.001, 0.001, 0.001])
    if cloud.crs:
        header.add_crs(pyproj.CRS.from_user_input(cloud.crs))
    las = laspy.LasData(header)
    las.x, las.y, las.z = cloud.xyz.T
    las.classification = cloud.labels.astype(np.uint8)
    las.write(str(path))


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default=".", help="folder for epoch1.laz and epoch2.laz")
    parser.add_argument("--folder", default=str(IGN), help="the tiles of epoch 1 (default: the six IGN tiles)")
    parser.add_argument("--vegetation", type=int, default=HIGH_VEGETATION,
                        help="class code of the vegetation removed (5 for IGN, 1 for AHN3)")
    parser.add_argument("--second", action="store_true",
                        help="also write epoch3.laz: epoch 2 edited again in other cells (a series)")
    args = parser.parse_args(argv)
    one, two, edits = edited_epochs(Path(args.folder), vegetation=args.vegetation)
    out = Path(args.out)
    write_las(one, out / "epoch1.laz")
    write_las(two, out / "epoch2.laz")
    print(f"epoch 1: {len(one):,} points, epoch 2: {len(two):,} points")
    for name, (x, y) in edits.items():
        print(f"{name}: cell centred at ({x:.1f}, {y:.1f})")
    if args.second:
        three, again = edit(two, seed=14, vegetation=args.vegetation, avoid=list(edits.values()), name="second edit")
        write_las(three, out / "epoch3.laz")
        print(f"epoch 3: {len(three):,} points")
        for name, (x, y) in again.items():
            print(f"{name} (epoch 2 to 3): cell centred at ({x:.1f}, {y:.1f})")


if __name__ == "__main__":
    main()
