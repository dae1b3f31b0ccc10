"""Tiled out-of-core runs against the single-process run, on synthetic LAZ files of 1M to 20M points.

    python benchmarks/bench_tiles.py [--sizes 1000000,5000000,20000000] [--workers 2] [--dir DIR]

For each size a LAZ file is generated (once, in DIR, default a temporary folder; never
committed): blocks of one million points of the airborne-like scene of bench_scaling.py
(terrain, gable roofs, tree crowns at 15 points per square metre) side by side, written in
chunks. Then end to end, default method (C3DCM, Multiscale k = 20, 30, 40, area weights):

- single: ``lidar-sig saliency big.laz -o out.laz`` and ``lidar-sig signature big.laz -o s.h5``
  (the whole cloud in one process);
- tiled: the same two commands with ``--workers N`` (tiles with halos, default tile size).

Every process of a run is sampled every 0.1 s (psutil): the peak resident set size of the main
process and of the largest worker, the wall time and points per second are printed. Timings on a
shared machine are noisy: compare the ratios of one run.
"""
from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_scaling import DENSITY, airborne_scene  # noqa: E402

BLOCK = 1_000_000  # points per generated block of scene


def make_laz(path, n):
    """Write ``n`` points of side-by-side scene blocks to ``path`` (LAS 1.4 point format 6, LAZ),
    one block in memory at a time."""
    import laspy

    blocks = max(1, n // BLOCK)
    per_row = int(np.ceil(np.sqrt(blocks)))
    side = np.sqrt(BLOCK / DENSITY)
    header = laspy.LasHeader(point_format=6, version="1.4")
    header.scales = [0.001, 0.001, 0.001]
    header.offsets = [500_000.0, 6_000_000.0, 0.0]
    with laspy.open(path, mode="w", header=header) as writer:
        for b in range(blocks):
            m = n - BLOCK * (blocks - 1) if b == blocks - 1 else BLOCK
            xyz = airborne_scene(m, seed=b)
            xyz[:, 0] += 500_000.0 + (b % per_row) * side
            xyz[:, 1] += 6_000_000.0 + (b // per_row) * side
            rec = laspy.ScaleAwarePointRecord.zeros(m, header=header)
            rec.x, rec.y, rec.z = xyz[:, 0], xyz[:, 1], xyz[:, 2]
            labels = np.full(m, 2, np.uint8)  # terrain, roofs, trees in that order
            labels[m - m // 4 - (15 * m) // 100:m - (15 * m) // 100] = 6
            labels[m - (15 * m) // 100:] = 5
            rec.classification = labels
            writer.write_points(rec)


def measure(args):
    """Run ``python -m lidar_sig args``; (wall seconds, peak RSS MiB of the main process, of the
    largest other process of its tree)."""
    import psutil

    start = time.monotonic()
    proc = subprocess.Popen([sys.executable, "-m", "lidar_sig", *map(str, args)], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    main = psutil.Process(proc.pid)
    peak_main, peak_worker = 0, 0
    while proc.poll() is None:
        try:
            peak_main = max(peak_main, main.memory_info().rss)
            for child in main.children(recursive=True):
                try:
                    peak_worker = max(peak_worker, child.memory_info().rss)
                except psutil.Error:
                    pass
        except psutil.Error:
            pass
        time.sleep(0.1)
    out, err = proc.communicate()
    if proc.returncode != 0:
        raise RuntimeError(f"lidar-sig {args} failed ({proc.returncode}):\n{err[-2000:]}")
    return time.monotonic() - start, peak_main / 2**20, peak_worker / 2**20, out


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--sizes", default="1000000,5000000,20000000")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--dir", default=None, help="where the generated files go (kept for reuse)")
    parser.add_argument("--skip-single-above", type=int, default=None,
                        help="run the single-process case only up to this many points")
    args = parser.parse_args()
    folder = Path(args.dir or tempfile.mkdtemp(prefix="lidar-sig-bench-"))
    folder.mkdir(parents=True, exist_ok=True)
    rows = []
    for n in (int(v) for v in args.sizes.split(",")):
        src = folder / f"synthetic_{n}.laz"
        if not src.exists():
            make_laz(src, n)
        cases = [("tiled", ["--workers", args.workers])]
        if args.skip_single_above is None or n <= args.skip_single_above:
            cases.insert(0, ("single", []))
        for name, extra in cases:
            out = folder / f"out_{name}_{n}"
            for stale in (out.with_suffix(".laz"), out.with_suffix(".h5")):
                stale.unlink(missing_ok=True)
            sal = out.with_suffix(".laz") if name == "single" else out
            if name == "tiled":
                subprocess.run(["rm", "-rf", str(out)], check=True)
            t1, m1, w1, _ = measure(["saliency", src, "-o", sal, "-q", *extra])
            t2, m2, w2, _ = measure(["signature", src, "-o", out.with_suffix(".h5"), "--no-points", "-q", *extra])
            row = {"case": name, "points": n, "saliency_s": round(t1, 1), "signature_s": round(t2, 1),
                   "points_per_s": round(2 * n / (t1 + t2)), "us_per_point": round(1e6 * (t1 + t2) / n, 2),
                   "peak_main_mib": round(max(m1, m2)), "peak_worker_mib": round(max(w1, w2))}
            rows.append(row)
            print(json.dumps(row), flush=True)
    print()
    print(f"{'case':<7} {'points':>11} {'saliency s':>11} {'signature s':>12} {'points/s':>10} {'us/point':>9} "
          f"{'main MiB':>9} {'worker MiB':>11}")
    for r in rows:
        print(f"{r['case']:<7} {r['points']:>11,} {r['saliency_s']:>11} {r['signature_s']:>12} "
              f"{r['points_per_s']:>10,} {r['us_per_point']:>9} {r['peak_main_mib']:>9} {r['peak_worker_mib']:>11}")


if __name__ == "__main__":
    main()
