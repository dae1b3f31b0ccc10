"""`lidar-sig saliency` end to end (read LAZ, saliency, write LAZ): wall time and peak memory.

    python benchmarks/bench_end_to_end.py ../shared/data/ahn3_delft/ahn3_cropped_1.laz [--runs 3]

Runs the installed command line once per strategy and run, as a user would, and prints the
median wall time and the median peak resident set size of the process.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _harness import cli_runs, median, table  # noqa: E402


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("file")
    parser.add_argument("--runs", type=int, default=3)
    args = parser.parse_args()
    strategies = ("multiscale", "optimal")
    walls, rss = cli_runs(args.file, {s: ("--strategy", s) for s in strategies}, args.runs)
    rows = [[s, f"{median(walls[s]):.2f}", f"{median(rss[s]):.0f}", f"{max(rss[s]):.0f}"] for s in strategies]
    print(f"lidar-sig saliency {args.file}: median of {args.runs} runs")
    table(rows, ["strategy", "wall s", "peak MiB (median)", "peak MiB (max)"])

if __name__ == "__main__":
    main()
