"""What differs between two campaigns, for the change map's power benchmark
(benchmarks/change_power.py, issue 38): real strip pairs and modelled campaign differences laid
on a later epoch, each also with the benchmark's edits (benchmarks/power_edits.py).

- **strips**: two overlapping flight strips of the survey (``point_source_id``), strip against
  strip: the same land seen from other positions (real occlusions, scan angles, strip offsets);
  edited, the edits are made to the second strip inside the cells both strips cover fully, one
  edit per pair (:func:`one_edit`): the overlap holds 18 to 31 compared cells, and five edits at
  once would make a sixth to a quarter of it change;
- **leaf-off**: :data:`LEAF_OFF` of the vegetation returns 2 m or more above the ground removed,
  and the ground under the crowns gained (its points there doubled, moved by up to
  :data:`GROUND_JITTER` m): deciduous trees without leaves;
- **misaligned**: each strip of the later epoch shifted by 5 to 20 cm in a random direction and
  tilted by 0.005 to 0.02 degrees about a random horizontal axis through its centre;
- **density x3**: the later epoch at three times the earlier's density;
- **class scheme**: the later epoch classified in another scheme (IGN: low, medium and high
  vegetation put in class 1, unclassified; AHN3: buildings and civil structures put in class 1),
  the pair compared with the class map that merges those classes on both sides.

Pure array functions but :func:`block_sources`, which reads the strips of a survey's files.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from edited_epoch import CELL, GROUND, _cells

#: Share of the vegetation returns 2 m or more above the ground that leaf-off removes.
LEAF_OFF = 0.8
#: Ground points gained under the crowns are copies moved by up to this, metres (x and y).
GROUND_JITTER = 0.5
#: Per-strip shift (m) and tilt (degrees) of the misaligned epoch: uniform in these ranges.
SHIFT_RANGE, TILT_RANGE = (0.05, 0.20), (0.005, 0.02)
#: Density of the later epoch against the earlier's for "density x3".
DENSITY_RATIO = 3.0
#: The later epoch's class scheme and the class map that compares the pair: {survey: (codes put
#: in class 1, class map)}.
SCHEMES = {"ign": ((3, 4, 5), "1,3,4,5=vegetation-or-other"),
           "ahn3": ((6, 26), "1,6,26=unclassified-or-built")}
#: Null kinds of campaign differences (each also "<kind> edited").
KINDS = ("strips", "leaf-off", "misaligned", "density x3", "class scheme")


def block_sources(source, n_points):
    """(N,) the ``point_source_id`` (flight strip) of each point of the survey block that
    :func:`lidar_sig.change_map.read_epoch` reads from ``source`` (a folder, or a list of files;
    the files in the same order)."""
    import laspy

    from lidar_sig.io import CLOUD_EXTENSIONS

    paths = (list(source) if isinstance(source, (list, tuple)) else
             sorted(p for p in Path(source).iterdir() if p.suffix.lower() in CLOUD_EXTENSIONS and p.is_file()))
    ids = np.concatenate([np.asarray(laspy.read(p).point_source_id, np.int64) for p in paths])
    if len(ids) != n_points:
        raise SystemExit(f"{source}: {len(ids)} strip ids for {n_points} points; the block was read otherwise")
    return ids


def strip_pair(xyz, source):
    """(first, second) strip ids of the two strips sharing the most full 25 m cells (cells
    holding more than half the median of each strip's cells), and the (N,) mask of the points
    in those shared cells."""
    ids = [k for k in np.unique(source) if (source == k).sum() > 0.05 * len(source)]
    cells = _cells(xyz[:, :2])
    key = cells[:, 0] * 1_000_003 + cells[:, 1]
    full = {}
    for k in ids:
        keys, n = np.unique(key[source == k], return_counts=True)
        full[k] = set(keys[n > 0.5 * np.median(n)].tolist())
    best = max(((a, b) for i, a in enumerate(ids) for b in ids[i + 1:]), key=lambda ab: len(full[ab[0]] & full[ab[1]]))
    shared = np.isin(key, list(full[best[0]] & full[best[1]]))
    return best, shared


def ground_level(xyz, labels, pixel=2.0):
    """(N,) the ground's z under each point (benchmarks/power_edits.py's rule)."""
    from power_edits import _ground_level

    return _ground_level(xyz, labels, pixel)


def leaf_off(xyz, labels, vegetation, rng, pixel=2.0):
    """(xyz, labels) of the epoch without leaves: :data:`LEAF_OFF` of its vegetation returns
    2 m or more above the ground removed, and its ground points in the 2 m pixels where returns
    were removed doubled (copies moved by up to :data:`GROUND_JITTER` m)."""
    height = xyz[:, 2] - ground_level(xyz, labels, pixel)
    crowns = (labels == vegetation) & (height >= 2.0)
    removed = crowns & (rng.random(len(xyz)) < LEAF_OFF)
    lo = xyz[:, :2].min(axis=0)
    pix = np.floor((xyz[:, :2] - lo) / pixel).astype(np.int64)
    key = pix[:, 0] * 1_000_003 + pix[:, 1]
    under = (labels == GROUND) & np.isin(key, np.unique(key[removed]))
    gained = xyz[under].copy()
    gained[:, :2] += rng.uniform(-GROUND_JITTER, GROUND_JITTER, (len(gained), 2))
    keep = ~removed
    return np.vstack([xyz[keep], gained]), np.concatenate([labels[keep], labels[under]])


def misaligned(xyz, source, rng):
    """(N, 3) the epoch with each strip moved by 5-20 cm in a random direction and tilted by
    0.005-0.02 degrees about a random horizontal axis through its centre."""
    out = xyz.copy()
    for k in np.unique(source):
        mine = source == k
        direction = rng.normal(size=3)
        shift = direction / np.linalg.norm(direction) * rng.uniform(*SHIFT_RANGE)
        angle = np.radians(rng.uniform(*TILT_RANGE))
        axis = rng.uniform(0.0, np.pi)
        ux, uy = np.cos(axis), np.sin(axis)  # a horizontal unit axis
        centre = xyz[mine].mean(axis=0)
        p = xyz[mine] - centre
        # Rodrigues' rotation about (ux, uy, 0) by angle
        k_cross = np.column_stack([uy * p[:, 2], -ux * p[:, 2], ux * p[:, 1] - uy * p[:, 0]])
        k_dot = ux * p[:, 0] + uy * p[:, 1]
        k_vec = np.array([ux, uy, 0.0])
        rotated = p * np.cos(angle) + k_cross * np.sin(angle) + np.outer(k_dot, k_vec) * (1 - np.cos(angle))
        out[mine] = rotated + centre + shift
    return out


def other_scheme(labels, survey):
    """(N,) the labels in the later epoch's other class scheme (:data:`SCHEMES`)."""
    codes, _ = SCHEMES[survey]
    return np.where(np.isin(labels, codes), 1, labels)


def edits_in(xyz, labels, mask, *, vegetation, rank=0):
    """(xyz, labels, edits) of the points with the benchmark's edits made to those of ``mask``
    (the cells where they may go) and the others kept as they are."""
    from power_edits import edit_block

    e_xyz, e_labels, edits = edit_block(xyz[mask], labels[mask], vegetation=vegetation, rank=rank)
    return np.vstack([e_xyz, xyz[~mask]]), np.concatenate([e_labels, labels[~mask]]), edits


def one_edit(xyz, labels, edited, kind):
    """(xyz, labels, {kind: cell}) with the single edit ``kind`` of ``edited`` (the (xyz,
    labels, edits) of :func:`edits_in` or power_edits.edit_block): the edited points inside its
    25 m cell, the unedited ones outside it (each edit lies inside its own cell)."""
    e_xyz, e_labels, edits = edited
    cell = np.asarray(edits[kind])
    inside = np.all(_cells(xyz[:, :2]) == cell, axis=1)
    e_inside = np.all(_cells(e_xyz[:, :2]) == cell, axis=1)
    return (np.vstack([e_xyz[e_inside], xyz[~inside]]), np.concatenate([e_labels[e_inside], labels[~inside]]),
            {kind: edits[kind]})


def cell_centre(cell):
    """(1, 2) x, y of the centre of the 25 m cell (i, j)."""
    i, j = cell
    return np.array([[(i + 0.5) * CELL, (j + 0.5) * CELL]])
