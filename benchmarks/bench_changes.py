"""Cost of the change map against the saliency it needs (issue 13, must-show 4; issue 17,
must-show 5).

Epoch A is FILE (default the 640,510-point AHN3 crop); epoch B is made from it in memory: moved
by (0.3, -0.2, 0.05) m, the building points (class 6) of one 25 m cell removed and 2% of the
points dropped at random. In one process, after a warm-up (compiled kernels, imports), each
round times both epochs' saliency alone (``Pipeline.saliency`` of A, then of B) and the whole
change map (``lidar_sig.changes(A, B)`` with its defaults: both saliencies, binning, per-cell
signatures and metrics, the level of detection), alternating which goes first; the ratio of the
medians is printed, and the change map's own steps (cell metrics, level of detection) from its
timings. Peak memory is measured apart, one child process per case (``os.wait4``'s peak
resident set size).

    python benchmarks/bench_changes.py [FILE] [--runs 3]
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))
DEFAULT = ROOT.parent / "shared" / "data" / "ahn3_delft" / "ahn3_cropped_1.laz"


def epochs(path):
    """(A, B) PointClouds: the file, and its edited, thinned and moved copy."""
    import lidar_sig as ls

    a = ls.read(path)
    rng = np.random.default_rng(4)
    cell = np.floor(a.xyz[:, :2] / 25.0)
    centre = np.floor(np.median(a.xyz[:, :2], axis=0) / 25.0)
    drop = (np.all(cell == centre, axis=1) & (a.labels == 6)) | (rng.random(len(a)) < 0.02)
    b = ls.PointCloud(a.xyz[~drop] + np.array([0.3, -0.2, 0.05]), a.labels[~drop], crs=a.crs, units=a.units,
                      path="edited copy")
    return a, b


def saliency_alone(pipeline, a, b):
    pipeline.saliency(a)
    pipeline.saliency(b)


def change_map(pipeline, a, b):
    import lidar_sig as ls

    return ls.changes(a, b, pipeline=pipeline)


CASES = {"saliency": saliency_alone, "changes": change_map}


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("file", nargs="?", default=str(DEFAULT))
    parser.add_argument("--runs", type=int, default=3)
    parser.add_argument("--worker", choices=sorted(CASES), help=argparse.SUPPRESS)
    args = parser.parse_args()
    import lidar_sig as ls

    pipeline = ls.Pipeline(progress=False)
    a, b = epochs(args.file)
    if args.worker:  # one case in a child process, for its peak memory
        start = time.perf_counter()
        CASES[args.worker](pipeline, a, b)
        print(json.dumps({"seconds": time.perf_counter() - start}))
        return
    # warm-up on a corner of the data: compiled kernels and the metrics' imports
    corner = a.xyz[:, 0] < np.quantile(a.xyz[:, 0], 0.2)
    small = ls.PointCloud(a.xyz[corner], a.labels[corner], crs=a.crs, units=a.units)
    ls.changes(small, small, pipeline=pipeline)
    times = {name: [] for name in CASES}
    steps = {"cells": [], "lod": []}
    result = None
    for r in range(args.runs):
        for name in (list(CASES) if r % 2 == 0 else list(CASES)[::-1]):
            start = time.perf_counter()
            out = CASES[name](pipeline, a, b)
            times[name].append(time.perf_counter() - start)
            if out is not None:
                result = out
                for k in steps:
                    steps[k].append(out.timings[k])
    med = {k: float(np.median(v)) for k, v in times.items()}
    print(f"epochs: A {len(a):,} points ({Path(args.file).name}), B {len(b):,} points (edited copy); "
          f"{result.grid.rows} x {result.grid.cols} cells of {result.cell:g} m, {int(result.table['valid'].sum())} "
          f"compared (at least {result.min_points:,} points), {result.n_significant} significant")
    print(f"change map steps: cell metrics median {np.median(steps['cells']):.2f} s, level of detection median "
          f"{np.median(steps['lod']):.2f} s of the change map's {med['changes']:.2f} s")
    for name, values in times.items():
        print(f"{name:>9}: median {med[name]:.2f} s of " + ", ".join(f"{v:.2f}" for v in values))
    ratio = med["changes"] / med["saliency"]
    rounds = [c / s for c, s in zip(times["changes"], times["saliency"])]
    print(f"ratio change map / both saliencies alone: {ratio:.2f} (medians); per round "
          + ", ".join(f"{v:.2f}" for v in rounds))
    from _harness import run_child

    for name in CASES:
        _, rss = run_child([__file__, args.file, "--worker", name])
        print(f"peak RSS, {name} alone in a child process: {rss:.0f} MiB")


if __name__ == "__main__":
    main()
