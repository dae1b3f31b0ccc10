"""How often the change map calls unchanged land significant, and whether it finds known edits
(issue 17): the share of significant cells per metric on pairs of real data.

Blocks: the six IGN LiDAR HD tiles of Montpellier joined (../shared/data/ign_lidarhd_montpellier)
and the two AHN3 crops of Delft joined (../shared/data/ahn3_delft). For each block:

- **halves**: two disjoint random halves of the block (nothing changed, each half at half the
  density);
- **60% + noise + shift**: the block against a random 60% of itself with 3 cm of Gaussian noise
  on every coordinate and moved by 0.3 m east (nothing changed; another density, noise and
  registration, as a second survey would differ);
- **edited**: the block against its edited copy (benchmarks/edited_epoch.py: a building removed,
  the vegetation of a cell removed, a box building added, 80% kept, moved by (0.3, -0.2,
  0.05) m; the vegetation class is 5 in IGN, 1 in AHN3), with 25 m cells;
- **sparse** (IGN only): two independent thinnings of the block to 0.3 points/m², the second
  with classes 3, 4, 5 put in class 1 (another survey's scheme), without options and with
  ``--class-map 1,3,4,5=vegetation-or-other``.

Every run uses the change map's defaults (cell and fewest points chosen from the densities, 95%
confidence). Printed: compared cells, the share of significant cells of the map (its score or
delta_H above its level, the two tests together at 95%) and per metric at 95% each (for the
edited pairs: the edited cells found significant, and the share of the other cells), the ranks
of the edited cells, and the time of the level-of-detection step against the change map's total.

    python benchmarks/change_noise.py [--seeds 0 1 2] [--blocks ign ahn3]
"""
from __future__ import annotations

import argparse
import sys
import time
import warnings
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))
DATA = ROOT.parent / "shared" / "data"
BLOCKS = {"ign": ("IGN block (6 tiles)", DATA / "ign_lidarhd_montpellier", 5),
          "ahn3": ("AHN3 pair (2 crops)", DATA / "ahn3_delft", 1)}
KEEP, NOISE, SHIFT = 0.6, 0.03, (0.3, 0.0, 0.0)
#: The sparse pair of tests/test_changes.py (must-show 3): points per m² and the codes the
#: second survey puts in class 1 (unclassified).
SPARSE_DENSITY, RECLASSIFIED = 0.3, (3, 4, 5)


def _part(cloud, keep, name, xyz=None):
    from lidar_sig.method.cloud import PointCloud

    xyz = cloud.xyz[keep] if xyz is None else xyz
    return PointCloud(xyz, cloud.labels[keep], path=name, crs=cloud.crs, units=cloud.units)


def halves(cloud, seed=0):
    """Two disjoint random halves of ``cloud``."""
    first = np.random.default_rng(seed).random(len(cloud)) < 0.5
    return _part(cloud, first, "first half"), _part(cloud, ~first, "second half")


def thinned_noisy(cloud, seed=0):
    """``cloud`` and a random 60% of it with 3 cm of Gaussian noise on x, y, z, moved 0.3 m east."""
    rng = np.random.default_rng(seed)
    keep = rng.random(len(cloud)) < KEEP
    xyz = cloud.xyz[keep] + rng.normal(0.0, NOISE, (int(keep.sum()), 3)) + np.asarray(SHIFT)
    return cloud, _part(cloud, keep, "60% + 3 cm noise + 0.3 m shift", np.round(xyz, 3))


def sparse_pair(cloud, seed=0, density=SPARSE_DENSITY):
    """Two independent thinnings of ``cloud`` to ``density`` points per m², the second with the
    vegetation (classes 3, 4, 5) classified as 1 (unclassified), as another survey's scheme."""
    from lidar_sig.change_map import density as density_of

    rng = np.random.default_rng(seed)
    share = density / density_of(cloud.xyz[:, :2], cloud.units.horizontal)
    a = _part(cloud, rng.random(len(cloud)) < share, "survey 1 (sparse)")
    b = _part(cloud, rng.random(len(cloud)) < share, "survey 2 (sparse, vegetation unclassified)")
    b.labels = np.where(np.isin(b.labels, RECLASSIFIED), 1, b.labels)
    return a, b


def shares(cm):
    """{"map" or metric: share of the compared cells significant in the map, or in the metric}."""
    n = int(cm.table["valid"].sum())
    out = {"map": cm.n_significant / n}
    out.update({k: v.significant.sum() / n for k, v in cm.levels.items() if np.isfinite(v.mu0).any()})
    return out


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2], help="seeds of the unchanged pairs")
    parser.add_argument("--blocks", nargs="+", choices=sorted(BLOCKS), default=["ign", "ahn3"])
    args = parser.parse_args()
    import lidar_sig as ls
    from edited_epoch import edit
    from lidar_sig.change_map import read_epoch
    from lidar_sig.base.errors import LidarSigWarning
    from lidar_sig.change_map._cells import CHANGE_KEYS
    from lidar_sig.change_map._maps import NAMES

    warnings.simplefilter("ignore", LidarSigWarning)  # the sparse pair's scheme warning is the point
    pipeline = ls.Pipeline(progress=False)
    keys = ("map",) + CHANGE_KEYS
    names = {"map": "map", **NAMES}
    header = "| block | pair | cells | " + " | ".join(names[k] for k in keys) + " |"
    rows, notes = [], []
    for key in args.blocks:
        title, folder, vegetation = BLOCKS[key]
        block = read_epoch(folder)
        runs = [(f"halves (seed {s})", halves(block, s), {}) for s in args.seeds]
        runs += [(f"60% + noise + shift (seed {s})", thinned_noisy(block, s), {}) for s in args.seeds]
        two, edits = edit(block, vegetation=vegetation)
        runs.append(("edited", (block, two), {"cell": 25}))
        for name, (a, b), options in runs:
            start = time.perf_counter()
            cm = ls.changes(a, b, pipeline=pipeline, **options)
            total = time.perf_counter() - start
            n = int(cm.table["valid"].sum())
            t = cm.timings
            notes.append(f"{title}, {name}: {n} cells of {cm.cell:g} m (min {cm.min_points:,} points), ranked by "
                         f"{names[cm.score]}; level of detection {t['lod']:.2f} s of {total:.2f} s (cell "
                         f"metrics {t['cells']:.2f} s, saliency {sum(t['saliency']):.2f} s)")
            if name != "edited":
                values = shares(cm)
                rows.append(f"| {title} | {name} | {n} | "
                            + " | ".join(f"{values[k]:.3f}" if k in values else "n/a" for k in keys) + " |")
                continue
            cells = [int(cm.grid.cell_of(np.array([xy]))[0]) for xy in edits.values()]
            others = cm.table["valid"].copy()
            others[cells] = False
            found = []
            for k in keys:
                flags = cm.table["significant"] if k == "map" else cm.levels[k].significant
                found.append(f"{sum(bool(flags[c]) for c in cells)} / {flags[others].sum() / others.sum():.3f}")
            rows.append(f"| {title} | edited: edits found / share of others | {n} | " + " | ".join(found) + " |")
            order = list(cm.ranked())
            ranks = ", ".join(f"{e} {order.index(c) + 1 if c in order else 'not compared'}"
                              for e, c in zip(edits, cells))
            notes.append(f"{title}, edited: ranks by {names[cm.score]}: {ranks}; "
                         f"{cm.n_significant} significant cells")
            notes.append(f"{title}, edited: z of the edited cells ({', '.join(edits)}): " + "; ".join(
                f"{names[k]} " + "/".join(f"{cm.levels[k].z[c]:.1f}" for c in cells) for k in CHANGE_KEYS))
        if key == "ign":  # the sparse pair of two class schemes (tests/test_changes.py, must-show 3)
            a, b = sparse_pair(block)
            for name, options in (("sparse, two schemes", {}),
                                  ("sparse, --class-map 1,3,4,5=vegetation-or-other",
                                   {"class_map": "1,3,4,5=vegetation-or-other"})):
                cm = ls.changes(a, b, pipeline=pipeline, **options)
                values, n = shares(cm), int(cm.table["valid"].sum())
                rows.append(f"| {title} | {name} | {n} | "
                            + " | ".join(f"{values[k]:.3f}" if k in values else "n/a" for k in keys) + " |")
                notes.append(f"{title}, {name}: {n} cells of {cm.cell:g} m (min {cm.min_points:,} points, densities "
                             + ", ".join(f"{d:.2f}" for d in cm.density) + f" points/m²), ranked by "
                             f"{names[cm.score]}; survey factors exp(beta): " + ", ".join(
                                 f"{names[k]} {np.exp(cm.levels[k].beta):.2f}" for k in CHANGE_KEYS))
    print(header)
    print("|" + "---|" * (3 + len(keys)))
    for row in rows:
        print(row)
    print()
    for line in notes:
        print(line)


if __name__ == "__main__":
    main()
