"""Share of point-type points per semantic class, per descriptor, on real tiles (SPEC 3).

    python benchmarks/point_type_shares.py ../shared/data/ign_lidarhd_montpellier/*.laz \
        [--thresholds 0,1e-3,1e-2,1e-1]

For each descriptor (C3DCM, T3DVT, and T3DVT-GET at each GET threshold) with the Multiscale
strategy and the paper's normalized radii, prints the share of points of ASPRS class 2
(ground), 6 (building) and 5 (high vegetation) whose deterministic geometric class is
point-type, over all the files together, and the share of each class turned into a corner by
GET. Points with undefined saliency are left out of the shares.
"""
from __future__ import annotations

import argparse
import sys

import numpy as np

import lidar_sig as ls
from lidar_sig.method.scales import PAPER_K, PAPER_RADII
from lidar_sig.plugins.descriptors.t3dvt_get import T3DVTGET

CLASSES = {2: "ground", 6: "building", 5: "high vegetation"}


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("files", nargs="+")
    parser.add_argument("--thresholds", default="0,1e-3,1e-2,1e-1")
    args = parser.parse_args()
    thresholds = [float(v) for v in args.thresholds.split(",")]
    configs = [("C3DCM", "c3dcm"), ("T3DVT", "t3dvt")]
    configs += [(f"T3DVT-GET, threshold {t:g}", T3DVTGET(get_threshold=t)) for t in thresholds]
    clouds = [ls.read(f) for f in args.files]
    rows = []
    t3dvt_class = {}
    for label, descriptor in configs:
        point, corner, total = {c: 0 for c in CLASSES}, {c: 0 for c in CLASSES}, {c: 0 for c in CLASSES}
        for i, cloud in enumerate(clouds):
            sal, _ = ls.Pipeline(descriptor=descriptor, scales=PAPER_RADII, weights="none",
                                 progress=False).saliency(cloud)
            if label == "T3DVT":
                t3dvt_class[i] = sal.geom_class
            for code in CLASSES:
                mask = (cloud.labels == code) & sal.defined
                total[code] += int(mask.sum())
                point[code] += int((sal.geom_class[mask] == 3).sum())
                if label.startswith("T3DVT-GET"):
                    # corners: GET replaced the voting saliency (Cs set to 0, point-type)
                    corner[code] += int(((sal.cs[mask] == 0) & (sal.geom_class[mask] == 3)
                                         & (t3dvt_class[i][mask] != 3)).sum())
        row = [label] + [f"{100 * point[c] / max(total[c], 1):.1f}%" for c in CLASSES]
        row += [f"{100 * corner[c] / max(total[c], 1):.1f}%" if label.startswith("T3DVT-GET") else "-"
                for c in CLASSES]
        rows.append(row)
    header = ["descriptor (Multiscale)"] + [f"point-type {n}" for n in CLASSES.values()]
    header += [f"new corners {n}" for n in CLASSES.values()]
    widths = [max(len(str(r[i])) for r in [header] + rows) for i in range(len(header))]
    print(f"{len(clouds)} files, {sum(len(c) for c in clouds):,} points; shares of points with defined saliency")
    for r in [header] + rows:
        print(" | ".join(str(v).ljust(w) for v, w in zip(r, widths)))


if __name__ == "__main__":
    sys.exit(main())
