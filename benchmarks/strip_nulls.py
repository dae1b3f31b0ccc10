"""Real nulls: overlapping flight strips of the shared surveys mapped strip against strip with
the change map's defaults (issue 38). Two passes over the same land, minutes to days apart,
from other positions: real occlusions, scan angles and strip offsets, almost no change. Printed
per pair: the densities, the compared cells, the significant and changed cells (changed: the
significant ones and the appeared or vanished cells inside the other strip's footprint), the
appeared or vanished cells at a strip's edge (not counted), the cells with a q-value below 5%,
and the totals over every pair.

Strips: ``point_source_id`` of each file's points; a strip of less than 5% of a block's points
is left out. Blocks: the six IGN LiDAR HD tiles of Montpellier joined, and each AHN3 crop of
Delft.

    python benchmarks/strip_nulls.py [--json FILE]
"""
from __future__ import annotations

import argparse
import json
import sys
import warnings
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))
DATA = ROOT.parent / "shared" / "data"
BLOCKS = {"IGN block": sorted((DATA / "ign_lidarhd_montpellier").glob("*.laz")),
          "AHN3 crop 1": [DATA / "ahn3_delft" / "ahn3_cropped_1.laz"],
          "AHN3 crop 2": [DATA / "ahn3_delft" / "ahn3_cropped_2.laz"]}
#: Strips holding less than this share of a block's points are left out (a few stray points).
LEAST_SHARE = 0.05


def strips(paths):
    """{point_source_id: PointCloud} of the strips of the files ``paths`` joined (read as the
    change map reads an epoch; the strip of each point from benchmarks/campaigns.py)."""
    from campaigns import block_sources

    from lidar_sig.change_map import read_epoch
    from lidar_sig.method.cloud import PointCloud

    block = read_epoch(list(paths))
    source = block_sources(list(paths), len(block.xyz))
    ids, counts = np.unique(source, return_counts=True)
    return {int(k): PointCloud(block.xyz[source == k], block.labels[source == k], crs=block.crs)
            for k in ids[counts >= LEAST_SHARE * len(source)]}


def strip_pair(a, b):
    """The change map of strip ``a`` against strip ``b`` with the defaults, as plain figures."""
    import lidar_sig as ls
    from lidar_sig.change_map import changes

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        cm = changes(a, b, pipeline=ls.Pipeline(progress=False))
    t = cm.table
    moved = cm.coverage_changes()
    return {"density": [round(float(d), 2) for d in cm.density], "compared": int(t["valid"].sum()),
            "significant": cm.n_significant, "changed": cm.n_changed,
            "coverage changed": moved["appeared"] + moved["vanished"], "at the edges": moved["at the edges"],
            "q below 5%": int((t["q"] < 0.05).sum())}


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--json", help="write the figures to this file")
    args = parser.parse_args(argv)
    rows = {}
    for block, paths in BLOCKS.items():
        if not all(p.exists() for p in paths):
            print(f"{block}: not found under {DATA}, left out")
            continue
        found = strips(paths)
        ids = sorted(found)
        for i, first in enumerate(ids):
            for second in ids[i + 1:]:
                name = f"{block}: {first} vs {second}"
                rows[name] = strip_pair(found[first], found[second])
                r = rows[name]
                print(f"{name:<28} densities {r['density'][0]:>5} {r['density'][1]:>5} points/m²  compared "
                      f"{r['compared']:>3}  significant {r['significant']}  changed {r['changed']}  coverage "
                      f"changed {r['coverage changed']} (edges not counted {r['at the edges']})  q < 5% "
                      f"{r['q below 5%']}", flush=True)
    total = {k: sum(r[k] for r in rows.values()) for k in ("compared", "significant", "changed", "coverage changed",
                                                            "at the edges", "q below 5%")}
    print(f"all {len(rows)} pairs: {total['changed']} of {total['compared']} compared cells changed "
          f"({total['changed'] / max(total['compared'], 1):.1%}; {total['significant']} significant, "
          f"{total['coverage changed']} by coverage, {total['at the edges']} edge cells not counted), "
          f"{total['q below 5%']} with q below 5%")
    if args.json:
        Path(args.json).write_text(json.dumps({"pairs": rows, "total": total}, indent=1))


if __name__ == "__main__":
    main()
