"""Time and peak memory of lidar_sig against the number of points, on synthetic airborne clouds.

    python benchmarks/bench_scaling.py [--sizes 100000,300000,1000000,3000000]

Each size runs in its own process: a deterministic airborne-like scene (terrain, gable roofs,
tree crowns at about 15 points per square metre) is generated, then both strategies run with
their defaults: Multiscale with k = 20, 30, 40, Optimal-scale with k = 10..100, area weights
(the paper's normalized radii would grow with the extent, and so would the work per point). Prints the
seconds, the microseconds per point and the peak resident set size of the process, then a
least-squares line through the peak memory: its slope is what each point costs (coordinates,
the sorted copy, the outputs), its intercept what does not grow with N (interpreter, libraries,
the neighbour-list buffers of one block).
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _harness import report, run_child, table, warm_up  # noqa: E402

DENSITY = 15.0  # points per square metre, like the AHN3 benchmark tile


def airborne_scene(n, seed=0, density=DENSITY):
    """n points: 60% terrain, 25% gable roofs, 15% tree crowns, over n / density square metres."""
    rng = np.random.default_rng(seed)
    side = np.sqrt(n / density)
    n_roof, n_tree = n // 4, (15 * n) // 100
    n_ground = n - n_roof - n_tree
    g = rng.uniform(0, side, (n_ground, 2))
    ground = np.column_stack([g, 2 * np.sin(g[:, 0] / 40) + 0.03 * rng.standard_normal(n_ground)])
    # roofs: 20 x 12 m gable roofs on a regular lot grid
    lots = max(1, int(side // 40))
    lot = rng.integers(0, lots, (n_roof, 2)) * 40.0
    local = rng.uniform([0, 0], [20, 12], (n_roof, 2))
    roof_z = 10 - 0.5 * np.abs(local[:, 1] - 6) + 0.03 * rng.standard_normal(n_roof)
    roof = np.column_stack([lot + 10 + local, roof_z])
    # trees: crowns of radius 3 m
    n_crowns = max(1, n_tree // 400)
    centres = np.column_stack([rng.uniform(0, side, (n_crowns, 2)), np.full(n_crowns, 8.0)])
    which = rng.integers(0, n_crowns, n_tree)
    tree = centres[which] + rng.normal(0, 1.5, (n_tree, 3))
    return np.vstack([ground, roof, tree])


def child(n):
    import lidar_sig as ls

    xyz = airborne_scene(n)
    cloud = ls.PointCloud(xyz)
    warm_up()
    out = {"points": n}
    for strategy in ("multiscale", "optimal"):
        start = time.perf_counter()
        ls.Pipeline(strategy=strategy, progress=False).saliency(cloud)
        out[strategy] = time.perf_counter() - start
    report(out)


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--sizes", default="100000,300000,1000000,3000000")
    parser.add_argument("--worker", type=int, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.worker:
        return child(args.worker)
    me = str(Path(__file__).resolve())
    rows, sizes, peaks = [], [], []
    for n in (int(v) for v in args.sizes.split(",")):
        out, rss = run_child([me, "--worker", str(n)])
        us = {s: out[s] / n * 1e6 for s in ("multiscale", "optimal")}
        rows.append([f"{n:,}", f"{out['multiscale']:.2f}", f"{us['multiscale']:.2f}",
                     f"{out['optimal']:.2f}", f"{us['optimal']:.2f}", f"{rss:.0f}"])
        sizes.append(n)
        peaks.append(rss)
    table(rows, ["points", "multiscale s", "us/pt", "optimal s", "us/pt", "peak MiB"])
    if len(sizes) > 1:
        slope, intercept = np.polyfit(sizes, peaks, 1)
        print(f"peak memory ~ {intercept:.0f} MiB + {slope * 2**20:.0f} bytes x points")


if __name__ == "__main__":
    main()
