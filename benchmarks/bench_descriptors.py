"""Multiscale T3DVT and T3DVT-GET against Multiscale C3DCM on the same file, same run.

    python benchmarks/bench_descriptors.py ../shared/data/ahn3_delft/ahn3_cropped_1.laz [--runs 3]

Each descriptor runs with the paper's Multiscale defaults (normalized radii 0.009, 0.010,
0.011) in its own child process, the descriptors alternating; prints the median saliency time
(search included, start-up and file reading excluded), its ratio to C3DCM, and the median peak
resident set size of the process.
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _harness import alternate, median, read_xyz, report, table, warm_up  # noqa: E402

DESCRIPTORS = ("c3dcm", "t3dvt", "t3dvt-get")


def child(descriptor, path):
    import lidar_sig as ls

    cloud = ls.PointCloud(read_xyz(path))
    warm_up(descriptors=(descriptor,))
    start = time.perf_counter()
    ls.Pipeline(descriptor=descriptor, progress=False).saliency(cloud)
    report({"seconds": time.perf_counter() - start, "points": len(cloud)})


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("file")
    parser.add_argument("--runs", type=int, default=3)
    parser.add_argument("--worker", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.worker:
        return child(args.worker, args.file)
    times, mem, points = alternate(str(Path(__file__).resolve()), args.file, DESCRIPTORS, args.runs)
    base = median(times["c3dcm"])
    rows = [[d, f"{median(times[d]):.2f}", f"{median(times[d]) / base:.2f}", f"{median(mem[d]):.0f}"]
            for d in DESCRIPTORS]
    print(f"{args.file}: {points:,} points, Multiscale, median of {args.runs} runs")
    table(rows, ["descriptor", "seconds", "ratio to c3dcm", "peak MiB"])


if __name__ == "__main__":
    main()
