"""Large files end to end: one command within the memory budget, against one block and explicit
tiles, on synthetic LAZ files of a given density.

    python benchmarks/bench_tiles.py [--sizes 1000000,20000000,100000000] [--density 20]
        [--cases auto] [--memory SIZE] [--workers 2] [--dir DIR] [--skip-single-above N]

For each size a LAZ file is generated (once, in DIR, default a temporary folder; never
committed): blocks of one million points of the airborne-like scene of bench_scaling.py
(terrain, gable roofs, tree crowns) at ``--density`` points per square metre (default 20), side
by side, written in chunks. Then end to end, default method (C3DCM, Multiscale k = 20, 30, 40,
area weights), the cases of ``--cases``:

- auto (the default): ``lidar-sig saliency big.laz -o out.laz`` with no option (``--memory``
  passed on when given): one block when the file fits the memory budget (1 GiB by default), else
  tiles in the command's own process, into the one output file;
- single: ``lidar-sig saliency big.laz -o out.laz`` and ``lidar-sig signature big.laz -o s.h5``
  as one block whatever the size (``--memory 1000G``);
- tiled: the same two commands with ``--workers N`` (tiles with halos, output to a folder);
- python: the notebook's line ``ls.Pipeline().run(big.laz).write(out.laz)`` in a Python process
  (``execution=ls.Execution(memory=...)`` when ``--memory`` is given): it decides as the command
  does, and its output is compared, dimension by dimension, with the auto case's when both run.

Every process of a run is sampled every 0.1 s (psutil): the peak resident set size of the main
process and of the largest worker, the wall time, microseconds per point and, for auto, that
figure relative to the smallest size's (the issue's bound: 1.2) are printed, with the line the
command printed about tiles. Timings on a shared machine are noisy: compare the ratios of one
run, and run the series on an idle machine.
"""
from __future__ import annotations

import argparse
import json
import re
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_scaling import airborne_scene  # noqa: E402

BLOCK = 1_000_000  # points per generated block of scene
#: Points per square metre of the series of issue 18.
DENSITY = 20.0


def make_laz(path, n, density=DENSITY):
    """Write ``n`` points of side-by-side scene blocks at ``density`` points per square metre to
    ``path`` (LAS 1.4 point format 6, LAZ), one block in memory at a time."""
    import laspy

    blocks = max(1, n // BLOCK)
    per_row = int(np.ceil(np.sqrt(blocks)))
    side = np.sqrt(BLOCK / density)
    header = laspy.LasHeader(point_format=6, version="1.4")
    header.scales = [0.001, 0.001, 0.001]
    header.offsets = [500_000.0, 6_000_000.0, 0.0]
    with laspy.open(path, mode="w", header=header) as writer:
        for b in range(blocks):
            m = n - BLOCK * (blocks - 1) if b == blocks - 1 else BLOCK
            xyz = airborne_scene(m, seed=b, density=density)
            xyz[:, 0] += 500_000.0 + (b % per_row) * side
            xyz[:, 1] += 6_000_000.0 + (b // per_row) * side
            rec = laspy.ScaleAwarePointRecord.zeros(m, header=header)
            rec.x, rec.y, rec.z = xyz[:, 0], xyz[:, 1], xyz[:, 2]
            labels = np.full(m, 2, np.uint8)  # terrain, roofs, trees in that order
            labels[m - m // 4 - (15 * m) // 100:m - (15 * m) // 100] = 6
            labels[m - (15 * m) // 100:] = 5
            rec.classification = labels
            writer.write_points(rec)


def measure(args, command=None):
    """Run ``python -m lidar_sig args`` (or ``command``); (wall seconds, peak RSS MiB of the main
    process, of the largest other process of its tree, stdout). Its output goes to files, not
    pipes: a long stdout (a JSON of every cell) would fill a pipe and stop the process."""
    import psutil

    start = time.monotonic()
    with tempfile.TemporaryFile("w+") as fo, tempfile.TemporaryFile("w+") as fe:
        proc = subprocess.Popen(command or [sys.executable, "-m", "lidar_sig", *map(str, args)], stdout=fo,
                                stderr=fe, text=True)
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
        fo.seek(0)
        fe.seek(0)
        out, err = fo.read(), fe.read()
    if proc.returncode != 0:
        raise RuntimeError(f"lidar-sig {args} failed ({proc.returncode}):\n{err[-2000:]}")
    return time.monotonic() - start, peak_main / 2**20, peak_worker / 2**20, out


def tiles_line(out):
    """What the command said about tiles ("one block" when it said nothing)."""
    found = re.search(r"processed in [\d,]+ tiles? of [\d.]+ m", out) or re.search(r"[\d,]+ tiles? of [\d.]+ m", out)
    return found.group(0) if found else "one block"


def run_case(name, src, folder, n, args):
    """One case on one file: a row of figures."""
    out = folder / f"out_{name}_{src.stem}"
    for stale in (out.with_suffix(".laz"), out.with_suffix(".h5")):
        stale.unlink(missing_ok=True)
    shutil.rmtree(out, ignore_errors=True)
    memory = ["--memory", args.memory] if args.memory else []
    if name == "auto":
        t, m, w, said = measure(["saliency", src, "-o", out.with_suffix(".laz"), *memory])
        return {"case": name, "points": n, "seconds": round(t, 1), "us_per_point": round(1e6 * t / n, 2),
                "peak_main_mib": round(m), "peak_worker_mib": round(w), "run": tiles_line(said)}
    if name == "python":
        execution = f"execution=ls.Execution(memory={args.memory!r})" if args.memory else ""
        code = (f"import lidar_sig as ls\nresult = ls.Pipeline().run({str(src)!r}{', ' if execution else ''}{execution})\n"
                f"result.write({str(out.with_suffix('.laz'))!r})\nprint('tiles' if result.tiled else 'one block')\n")
        t, m, w, said = measure(None, [sys.executable, "-c", code])
        auto = folder / f"out_auto_{src.stem}.laz"
        same = identical(auto, out.with_suffix(".laz")) if auto.exists() else "auto not run"
        return {"case": name, "points": n, "seconds": round(t, 1), "us_per_point": round(1e6 * t / n, 2),
                "peak_main_mib": round(m), "peak_worker_mib": round(w), "run": said.strip(),
                "same_as_auto": same}
    extra = ["--memory", "1000G"] if name == "single" else ["--workers", args.workers, *memory]
    sal = out.with_suffix(".laz") if name == "single" else out
    t1, m1, w1, said = measure(["saliency", src, "-o", sal, "-q", *extra])
    t2, m2, w2, _ = measure(["signature", src, "-o", out.with_suffix(".h5"), "--no-points", "-q", *extra])
    return {"case": name, "points": n, "seconds": round(t1 + t2, 1), "saliency_s": round(t1, 1),
            "signature_s": round(t2, 1), "us_per_point": round(1e6 * (t1 + t2) / (2 * n), 2),
            "peak_main_mib": round(max(m1, m2)), "peak_worker_mib": round(max(w1, w2)),
            "run": "one block" if name == "single" else f"{args.workers} workers"}


def identical(a, b):
    """Whether two LAS/LAZ files hold the same points, dimension by dimension (NaN equal to NaN),
    read chunk by chunk."""
    import laspy

    with laspy.open(a) as ra, laspy.open(b) as rb:
        if ra.header.point_count != rb.header.point_count:
            return False
        names = list(ra.header.point_format.dimension_names)
        if names != list(rb.header.point_format.dimension_names):
            return False
        for ca, cb in zip(ra.chunk_iterator(2_000_000), rb.chunk_iterator(2_000_000)):
            for dim in names:
                if not np.array_equal(np.asarray(ca[dim]), np.asarray(cb[dim]), equal_nan=True):
                    return False
    return True


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--sizes", default="1000000,20000000,100000000")
    parser.add_argument("--density", type=float, default=DENSITY, help="points per square metre [20]")
    parser.add_argument("--cases", default="auto", help="comma-separated: auto, single, tiled, python [auto]")
    parser.add_argument("--memory", default=None, help="--memory passed to the commands (auto and tiled)")
    parser.add_argument("--workers", type=int, default=2, help="workers of the tiled case [2]")
    parser.add_argument("--dir", default=None, help="where the generated files go (kept for reuse)")
    parser.add_argument("--skip-single-above", type=int, default=None,
                        help="run the single case only up to this many points")
    args = parser.parse_args()
    cases = [c.strip() for c in args.cases.split(",")]
    unknown = set(cases) - {"auto", "single", "tiled", "python"}
    if unknown:
        parser.error(f"unknown cases: {', '.join(sorted(unknown))}")
    folder = Path(args.dir or tempfile.mkdtemp(prefix="lidar-sig-bench-"))
    folder.mkdir(parents=True, exist_ok=True)
    rows = []
    for n in (int(v) for v in args.sizes.split(",")):
        src = folder / f"synthetic_{n}_{args.density:g}pm2.laz"
        if not src.exists():
            make_laz(src, n, args.density)
        for name in cases:
            if name == "single" and args.skip_single_above is not None and n > args.skip_single_above:
                continue
            row = run_case(name, src, folder, n, args)
            rows.append(row)
            print(json.dumps(row), flush=True)
    first = {}
    for r in rows:  # time per point relative to the smallest size of the same case
        first.setdefault(r["case"], r["us_per_point"])
        r["relative"] = round(r["us_per_point"] / first[r["case"]], 2)
    print()
    print(f"{args.density:g} points/m²; µs/point of saliency and signature averaged for single and tiled")
    print(f"{'case':<7} {'points':>12} {'seconds':>9} {'µs/point':>9} {'relative':>9} {'main MiB':>9} "
          f"{'worker MiB':>11}  run")
    for r in rows:
        same = f", same as auto: {r['same_as_auto']}" if "same_as_auto" in r else ""
        print(f"{r['case']:<7} {r['points']:>12,} {r['seconds']:>9} {r['us_per_point']:>9} {r['relative']:>9} "
              f"{r['peak_main_mib']:>9} {r['peak_worker_mib']:>11}  {r['run']}{same}")


if __name__ == "__main__":
    main()
