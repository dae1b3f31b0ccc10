"""Every comparison metric for four cases of growing difference, on real data (issue 4).

    python benchmarks/metric_cases.py [--data ../shared/data]

C3DCM, Multiscale, ASPRS classes; once with the paper's normalized radii, once with metric
radii 1.0, 1.1, 1.2 m (the same neighbourhoods in every cloud). Cases:
(a) an IGN tile against a copy rotated 30 degrees about z around its centre;
(b) the same tile against a uniform random 80% subsample of itself;
(c) the west IGN column (77050_627755 + 77050_627760) against the east column (77060_*);
(d) the IGN tile against the AHN3 Delft tile ahn3_cropped_2.
"""
from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

import lidar_sig as ls

KEYS = ("bhattacharyya", "ssim", "emd_info", "emd_img", "fv", "kl", "l1")
NAMES = ("d_BD-Img", "s_SSIM", "d_EMD-Info", "d_EMD-Img", "delta_FV", "delta_KL", "L1")


def merged(paths):
    clouds = [ls.read(p) for p in paths]
    return ls.PointCloud(np.vstack([c.xyz for c in clouds]), np.concatenate([c.labels for c in clouds]),
                         path=" + ".join(Path(p).name for p in paths))


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--data", default=str(Path(__file__).resolve().parents[2] / "shared" / "data"))
    args = parser.parse_args()
    ign = Path(args.data) / "ign_lidarhd_montpellier"
    tile = ls.read(ign / "test_data_77055_627755_LA93_IGN69.laz")
    centre = tile.xyz.mean(axis=0)
    a = np.radians(30.0)
    rot = np.array([[np.cos(a), -np.sin(a), 0], [np.sin(a), np.cos(a), 0], [0, 0, 1]])
    rotated = ls.PointCloud((tile.xyz - centre) @ rot.T + centre, tile.labels)
    keep = np.random.default_rng(0).random(len(tile)) < 0.8
    sub = ls.PointCloud(tile.xyz[keep], tile.labels[keep])
    west = merged([ign / "test_data_77050_627755_LA93_IGN69.laz", ign / "test_data_77050_627760_LA93_IGN69.laz"])
    east = merged([ign / "test_data_77060_627755_LA93_IGN69.laz", ign / "test_data_77060_627760_LA93_IGN69.laz"])
    delft = ls.read(Path(args.data) / "ahn3_delft" / "ahn3_cropped_2.laz")
    for title, scales in (("normalized radii 0.009, 0.010, 0.011", None),
                          ("metric radii 1.0, 1.1, 1.2 m", ls.radii(1.0, 1.1, 1.2, units="metric"))):
        pipe = ls.Pipeline(scales=scales, progress=False)
        base = pipe.run(tile).signature
        cases = [("(a) tile vs rotated 30 deg", base, pipe.run(rotated).signature),
                 ("(b) tile vs 80% subsample", base, pipe.run(sub).signature),
                 ("(c) west vs east column", pipe.run(west).signature, pipe.run(east).signature),
                 ("(d) IGN tile vs AHN3 Delft", base, pipe.run(delft).signature)]
        print(f"\nC3DCM Multiscale, {title}\n")
        print("| case | " + " | ".join(NAMES) + " |")
        print("|---" * (len(NAMES) + 1) + "|")
        for label, s1, s2 in cases:
            m = ls.compare(s1, s2)
            print(f"| {label} | " + " | ".join(f"{m[k]:.4f}" for k in KEYS) + " |")


if __name__ == "__main__":
    main()
