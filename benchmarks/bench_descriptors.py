"""Multiscale T3DVT and T3DVT-GET against Multiscale C3DCM on the same file, same run.

    python benchmarks/bench_descriptors.py ../shared/data/ahn3_delft/ahn3_cropped_1.laz [--runs 3]

Each descriptor runs with the paper's Multiscale defaults (normalized radii 0.009, 0.010,
0.011), the descriptors alternating, two ways:
* compute: in a child process, the saliency alone (search included; start-up and file reading
  excluded);
* end to end: `lidar-sig saliency FILE -o OUT.laz --descriptor D`, as a user runs it (start-up,
  reading LAZ, saliency, writing LAZ).
Prints the medians, the ratios to C3DCM and the median peak resident set size.
"""
from __future__ import annotations

import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _harness import alternate, cli_runs, file_runs_args, median, read_xyz, report, table, warm_up  # noqa: E402,E501

DESCRIPTORS = ("c3dcm", "t3dvt", "t3dvt-get")


def child(descriptor, path):
    import lidar_sig as ls
    from lidar_sig.method.scales import PAPER_RADII

    cloud = ls.PointCloud(read_xyz(path))
    warm_up(descriptors=(descriptor,))
    start = time.perf_counter()
    ls.Pipeline(descriptor=descriptor, scales=PAPER_RADII, weights="none", progress=False).saliency(cloud)
    report({"seconds": time.perf_counter() - start, "points": len(cloud)})


def main():
    args = file_runs_args(__doc__)
    if args.worker:
        return child(args.worker, args.file)
    times, mem, points = alternate(str(Path(__file__).resolve()), args.file, DESCRIPTORS, args.runs)
    walls, wall_mem = cli_runs(args.file, {d: ("--descriptor", d) for d in DESCRIPTORS}, args.runs)
    base, wall_base = median(times["c3dcm"]), median(walls["c3dcm"])
    rows = [[d, f"{median(times[d]):.2f}", f"{median(times[d]) / base:.2f}", f"{median(mem[d]):.0f}",
             f"{median(walls[d]):.2f}", f"{median(walls[d]) / wall_base:.2f}", f"{median(wall_mem[d]):.0f}"]
            for d in DESCRIPTORS]
    print(f"{args.file}: {points:,} points, Multiscale, median of {args.runs} runs")
    table(rows, ["descriptor", "compute s", "ratio", "peak MiB", "end-to-end s", "ratio", "peak MiB"])


if __name__ == "__main__":
    main()
