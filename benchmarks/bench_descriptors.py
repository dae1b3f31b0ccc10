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

import argparse
import shutil
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _harness import alternate, median, read_xyz, report, run_child, table, warm_up  # noqa: E402

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
    walls, wall_mem = end_to_end(args.file, args.runs)
    base, wall_base = median(times["c3dcm"]), median(walls["c3dcm"])
    rows = [[d, f"{median(times[d]):.2f}", f"{median(times[d]) / base:.2f}", f"{median(mem[d]):.0f}",
             f"{median(walls[d]):.2f}", f"{median(walls[d]) / wall_base:.2f}", f"{median(wall_mem[d]):.0f}"]
            for d in DESCRIPTORS]
    print(f"{args.file}: {points:,} points, Multiscale, median of {args.runs} runs")
    table(rows, ["descriptor", "compute s", "ratio", "peak MiB", "end-to-end s", "ratio", "peak MiB"])


def end_to_end(file, runs):
    """Median wall time and peak RSS of `lidar-sig saliency` per descriptor, alternating."""
    exe = shutil.which("lidar-sig")
    if exe is None:
        sys.exit("lidar-sig is not on PATH: install the package first (pip install -e .)")
    walls = {d: [] for d in DESCRIPTORS}
    mem = {d: [] for d in DESCRIPTORS}
    with tempfile.TemporaryDirectory() as tmp:
        out = str(Path(tmp) / "out.laz")
        for d in DESCRIPTORS:  # warm the file cache and the compiled kernels
            run_child([exe, "saliency", file, "-o", out, "--descriptor", d, "--overwrite", "-q"], python=False)
        for _ in range(runs):
            for d in DESCRIPTORS:
                wall, rss = run_child([exe, "saliency", file, "-o", out, "--descriptor", d, "--overwrite", "-q"],
                                      python=False)
                walls[d].append(wall)
                mem[d].append(rss)
    return walls, mem


if __name__ == "__main__":
    main()
