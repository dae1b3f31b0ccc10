"""lidar_sig against pgeof and jakteristics on the same work, same file, same run.

    python benchmarks/bench_peers.py ../shared/data/ahn3_delft/ahn3_cropped_1.laz [--runs 3]

Cases (DESIGN.md, "Performance approach"; the peers come from the ``bench`` extra):

* Optimal-scale C3DCM, k = 10..100 step 10, search included, against pgeof ``knn_search``
  (k = 100) then ``compute_features_optimal(k_min=10, k_step=10, k_min_search=10)``.
* Multiscale C3DCM with the paper's three normalized radii resolved to metres of the file,
  search included, against jakteristics ``compute_features`` at the same three radii with
  ``max_k_neighbors`` equal to lidar_sig's cap (512).

Both lidar_sig cases weigh neighbours equally (``weights="none"``), as the peers do, so that the
work is the same on both sides.

Each figure is the median of ``--runs`` child processes per tool, the tools alternating. Times
exclude start-up and reading the file; peak memory is the resident set size of the whole
child process. A correctness cross-check follows: at k = 50, linearity and planarity from
lidar_sig's eigenvalues, computed as pgeof defines them (square roots of the eigenvalues,
divided by sqrt(l0) + 1e-3), must agree with pgeof's within 1e-4 for 99.9% of the points
whose 50-neighbourhood is unique (no tie between the 50th and 51st neighbour distances).
"""
from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _harness import alternate, file_runs_args, median, read_xyz, report, table, warm_up  # noqa: E402

PAPER_RADII = (0.009, 0.010, 0.011)
K_SCALES = tuple(range(10, 101, 10))
MAX_NEIGHBORS = 512


def metric_radii(xyz):
    return [r * float((xyz.max(axis=0) - xyz.min(axis=0)).max()) / 2.0 for r in PAPER_RADII]


def child(case, path):
    xyz = read_xyz(path)
    if case.startswith("lidar_sig"):
        import lidar_sig as ls

        if case == "lidar_sig-optimal":
            pipe = ls.Pipeline(strategy="optimal", scales=ls.knn(*K_SCALES), weights="none", progress=False)
        else:
            pipe = ls.Pipeline(strategy="multiscale", progress=False, max_neighbors=MAX_NEIGHBORS,
                               scales=ls.radii(*metric_radii(xyz), units="metric"), weights="none")
        warm_up()
        cloud = ls.PointCloud(xyz)
        start = time.perf_counter()
        sal, _ = pipe.saliency(cloud)
        elapsed = time.perf_counter() - start
    elif case == "pgeof":
        import pgeof

        x32 = np.ascontiguousarray(xyz, dtype=np.float32)
        start = time.perf_counter()
        nn, _ = pgeof.knn_search(x32, x32, K_SCALES[-1])
        ptr = np.arange(0, nn.size + 1, K_SCALES[-1], dtype=np.uint32)
        pgeof.compute_features_optimal(x32, nn.ravel(), ptr, k_min=10, k_step=10, k_min_search=10)
        elapsed = time.perf_counter() - start
    elif case == "jakteristics":
        import jakteristics

        xyz = np.ascontiguousarray(xyz)
        start = time.perf_counter()
        for r in metric_radii(xyz):
            jakteristics.compute_features(xyz, r, max_k_neighbors=MAX_NEIGHBORS,
                                          feature_names=["linearity", "planarity", "sphericity"])
        elapsed = time.perf_counter() - start
    else:
        raise SystemExit(f"unknown case {case}")
    report({"case": case, "seconds": elapsed, "points": len(xyz)})


def cross_check(path):
    """Linearity and planarity at k = 50: lidar_sig eigenvalues against pgeof.

    Points whose 50th and 51st neighbours are equally far have no unique 50-neighbourhood
    (common with coordinates quantized to 1 cm): the two tools may pick different points there,
    so they are counted apart.
    """
    import pgeof

    from lidar_sig.numerics.kernels import covariance_eigenvalues
    from lidar_sig.numerics.neighbors import NeighborIndex

    xyz = read_xyz(path)
    x32 = np.ascontiguousarray(xyz, dtype=np.float32)
    nn, _ = pgeof.knn_search(x32, x32, 50)
    ptr = np.arange(0, nn.size + 1, 50, dtype=np.uint32)
    ref = pgeof.compute_features(x32, nn.ravel(), ptr, k_min=1)[:, :2]
    index = NeighborIndex(xyz, "knn", np.array([50, 51]))
    ev = np.empty((len(xyz), 3))
    tie = np.empty(len(xyz), bool)
    for rows in index.blocks():
        batch = index.query(rows)
        ev[batch.ids] = covariance_eigenvalues(batch.xyz, batch.rows, batch.idx, batch.counts, batch.weights)[:, 0]
        d = batch.dist
        tie[batch.ids] = d[:, 50] - d[:, 49] <= 1e-9 * d[:, 50]
    s = np.sqrt(ev)
    denom = s[:, 0] + 1e-3  # pgeof's stabilizing epsilon
    ours = np.column_stack([(s[:, 0] - s[:, 1]) / denom, (s[:, 1] - s[:, 2]) / denom])
    ok = np.abs(ours - ref).max(axis=1) <= 1e-4
    share = float(ok[~tie].mean())
    print(f"\ncross-check at k = 50 against pgeof (linearity, planarity within 1e-4): "
          f"{share:.4%} of the {int((~tie).sum()):,} points with a unique 50-neighbourhood agree "
          f"(required 99.9%); all points: {ok.mean():.4%} ({int(tie.sum()):,} have a tie at the "
          f"50th neighbour)")
    return share >= 0.999


def main():
    args = file_runs_args(__doc__)
    if args.worker:
        return child(args.worker, args.file)
    me = str(Path(__file__).resolve())
    rows = []
    for ours, peer, label in (("lidar_sig-optimal", "pgeof", "Optimal-scale C3DCM k=10..100"),
                              ("lidar_sig-multiscale", "jakteristics", "Multiscale C3DCM 3 radii")):
        times, mem, points = alternate(me, args.file, (ours, peer), args.runs)
        t_ours, t_peer = median(times[ours]), median(times[peer])
        rows.append([label, peer, f"{t_ours:.2f}", f"{t_peer:.2f}", f"{t_ours / t_peer:.2f}",
                     f"{median(mem[ours]):.0f}", f"{median(mem[peer]):.0f}"])
    print(f"{args.file}: {points:,} points, median of {args.runs} runs per tool (seconds, MiB)")
    table(rows, ["case", "peer", "lidar_sig s", "peer s", "ratio", "lidar_sig MiB", "peer MiB"])
    ok = cross_check(args.file)
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
