"""The shape of the change map's time on a Dask cluster (issue 37, docs/scale-out.md): one pair of
synthetic epochs (benchmarks/bench_change_scale.py, 4 million points each by default) mapped in
work units on a local dask.distributed cluster of 1, 2 and 4 worker processes of one thread.

    python benchmarks/change_scale_dask.py [--points 4000000] [--workers 1,2,4] [--dir DIR]

Per cluster size it prints the wall time of ``lidar_sig.changes(A, B, execution=Execution(
scheduler=...))`` and of its phases: each epoch's saliency in tiles, the densities, the coding
of the tiles' points, the work units, and what the main process does alone (the survey part
over every cell, the ranking). On a machine of two cores, 4 workers share them: the parallel
phases cannot go faster than with 2, which is the shape the model of docs/scale-out.md predicts
past the cores.
"""
from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_change_scale import edit_squares, make_edited  # noqa: E402
from bench_tiles import make_laz  # noqa: E402


def main():
    import distributed

    import lidar_sig as ls

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--points", type=int, default=4_000_000, help="points of epoch A")
    parser.add_argument("--workers", default="1,2,4")
    parser.add_argument("--dir", default=None)
    args = parser.parse_args()
    folder = Path(args.dir or tempfile.mkdtemp(prefix="change-scale-dask-"))
    folder.mkdir(parents=True, exist_ok=True)
    a, b = folder / f"a_{args.points}.laz", folder / f"b_{args.points}.laz"
    if not a.is_file():
        make_laz(a, args.points)
    if not b.is_file():
        make_edited(a, b, edit_squares(args.points))
    print(f"{'workers':>7} {'wall s':>7} {'saliency A':>10} {'saliency B':>10} {'densities':>9} {'coding':>7} "
          f"{'units':>7} {'main alone':>10} {'units n':>7} {'significant':>11}")
    for n in (int(w) for w in args.workers.split(",")):
        with distributed.LocalCluster(n_workers=n, threads_per_worker=1, processes=True, dashboard_address=None,
                                      memory_limit=None) as cluster:
            start = time.perf_counter()
            cm = ls.changes(str(a), str(b), execution=ls.Execution(scheduler=cluster.scheduler_address),
                            pipeline=ls.Pipeline(progress=False))
            wall = time.perf_counter() - start
        t = cm.timings
        sal_a, sal_b = t["saliency"]
        alone = wall - sal_a - sal_b - t["densities_seconds"] - t["coding_seconds"] - t["units_seconds"]
        print(f"{n:>7} {wall:>7.1f} {sal_a:>10.1f} {sal_b:>10.1f} {t['densities_seconds']:>9.1f} "
              f"{t['coding_seconds']:>7.1f} {t['units_seconds']:>7.1f} {alone:>10.1f} {t['units']['units']:>7} "
              f"{cm.n_significant:>11}", flush=True)
        cm.close()


if __name__ == "__main__":
    main()
