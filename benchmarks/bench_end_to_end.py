"""`lidar-sig saliency` end to end (read LAZ, saliency, write LAZ): wall time and peak memory.

    python benchmarks/bench_end_to_end.py ../shared/data/ahn3_delft/ahn3_cropped_1.laz [--runs 3]

Runs the installed command line once per strategy and run, as a user would, and prints the
median wall time and the median peak resident set size of the process.
"""
from __future__ import annotations

import argparse
import shutil
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _harness import median, run_child, table  # noqa: E402


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("file")
    parser.add_argument("--runs", type=int, default=3)
    args = parser.parse_args()
    exe = shutil.which("lidar-sig")
    if exe is None:
        sys.exit("lidar-sig is not on PATH: install the package first (pip install -e .)")
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        out = str(Path(tmp) / "out.laz")
        for strategy in ("multiscale", "optimal"):
            cmd = [exe, "saliency", args.file, "-o", out, "--strategy", strategy, "--overwrite", "-q"]
            run_child(cmd, python=False)  # warm the file cache and the compiled kernels
            walls, rss = [], []
            for _ in range(args.runs):
                wall, peak = run_child(cmd, python=False)
                walls.append(wall)
                rss.append(peak)
            rows.append([strategy, f"{median(walls):.2f}", f"{median(rss):.0f}", f"{max(rss):.0f}"])
    print(f"lidar-sig saliency {args.file}: median of {args.runs} runs")
    table(rows, ["strategy", "wall s", "peak MiB (median)", "peak MiB (max)"])


if __name__ == "__main__":
    main()
