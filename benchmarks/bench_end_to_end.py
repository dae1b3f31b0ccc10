"""`lidar-sig saliency` end to end (read LAZ, saliency, write LAZ): wall time and peak memory.

    python benchmarks/bench_end_to_end.py ../shared/data/ahn3_delft/ahn3_cropped_1.laz [--runs 3]

Runs the installed command line once per case and run, as a user would, the cases alternating,
and prints the median wall time and the median peak resident set size of the process. Cases: the
defaults (Multiscale, k = 20, 30, 40, area weights), the paper's setting (Multiscale, normalized
radii 0.009, 0.010, 0.011, neighbours weighed equally) and the default Optimal-scale; then the
ratio of the defaults' time to the paper setting's.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _harness import cli_runs, median, table  # noqa: E402

#: The paper's setting (SPEC 2): Multiscale at three normalized radii, neighbours weighed equally.
PAPER = ("--units", "normalized", "--radii", "0.009,0.010,0.011", "--weights", "none")


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("file")
    parser.add_argument("--runs", type=int, default=3)
    args = parser.parse_args()
    cases = {"defaults": (), "paper": PAPER, "optimal": ("--strategy", "optimal")}
    walls, rss = cli_runs(args.file, cases, args.runs)
    rows = [[c, f"{median(walls[c]):.2f}", f"{median(rss[c]):.0f}", f"{max(rss[c]):.0f}"] for c in cases]
    print(f"lidar-sig saliency {args.file}: median of {args.runs} runs")
    table(rows, ["case", "wall s", "peak MiB (median)", "peak MiB (max)"])
    pairs = [a / b for a, b in zip(walls["defaults"], walls["paper"])]
    print(f"defaults / paper's setting: {median(walls['defaults']) / median(walls['paper']):.2f} "
          f"(round by round {min(pairs):.2f} to {max(pairs):.2f})")

if __name__ == "__main__":
    main()
