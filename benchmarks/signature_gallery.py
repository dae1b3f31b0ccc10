"""The signatures of one tile for the configurations the paper discusses, in one PNG.

    python benchmarks/signature_gallery.py \
        ../shared/data/ign_lidarhd_montpellier/test_data_77055_627755_LA93_IGN69.laz -o gallery.png

Panels: Multiscale C3DCM, Optimal-scale C3DCM, Multiscale T3DVT, Optimal-scale T3DVT,
Multiscale T3DVT-GET and raw (undiffused) Multiscale T3DVT; each the augmented semantic
signature Sas with the paper's four classes (tree green, building red, low vegetation
yellow-green, road grey), paper default scales. docs/descriptors.md describes what shows.
"""
from __future__ import annotations

import argparse
from pathlib import Path

import cv2
import numpy as np

import lidar_sig as ls
from lidar_sig.io.png import write_png
from lidar_sig.plugins.descriptors.t3dvt import T3DVT
from lidar_sig.reporting.render import signature_image

CONFIGS = [
    ("Multiscale C3DCM", "c3dcm", "multiscale"),
    ("Optimal-scale C3DCM", "c3dcm", "optimal"),
    ("Multiscale T3DVT", "t3dvt", "multiscale"),
    ("Optimal-scale T3DVT", "t3dvt", "optimal"),
    ("Multiscale T3DVT-GET", "t3dvt-get", "multiscale"),
    ("raw T3DVT (no diffusion), Multiscale", T3DVT(diffusion=False), "multiscale"),
]


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("file")
    parser.add_argument("-o", "--output", required=True)
    parser.add_argument("--size", type=int, default=400, help="pixels per panel")
    args = parser.parse_args()
    cloud = ls.read(args.file)
    frame = ls.Frame(args.size, margin=max(8, args.size // 32))
    panels = []
    for title, descriptor, strategy in CONFIGS:
        # the paper's setting: its scales, plain means; the density rendering of the figure
        scales = ls.scales.PAPER_RADII if strategy == "multiscale" else ls.scales.PAPER_K
        result = ls.Pipeline(descriptor=descriptor, strategy=strategy, scales=scales, weights="none",
                             classes="paper", frame=frame, progress=False).run(cloud)
        img = signature_image(result.signature, "sas", mode="density")
        cv2.putText(img, title, (6, 14), cv2.FONT_HERSHEY_SIMPLEX, 0.4, (0, 0, 0), 1, cv2.LINE_AA)
        cv2.putText(img, f"{result.signature.n_points:,} points", (6, 28), cv2.FONT_HERSHEY_SIMPLEX, 0.4,
                    (90, 90, 90), 1, cv2.LINE_AA)
        panels.append(img)
        print(f"{title}: {result.signature.n_points:,} points in the signature, "
              f"{result.metadata['n_undefined']:,} undefined")
    rows = [np.hstack(panels[i:i + 3]) for i in (0, 3)]
    write_png(args.output, np.vstack(rows), overwrite=True)
    print(f"wrote {args.output} ({Path(args.file).name})")


if __name__ == "__main__":
    main()
