"""Every process of a change map within ``--memory`` (issue 46): ``lidar-sig changes`` on real
data at a few budgets, in one block and in work units, each process of the run's tree sampled.

    python benchmarks/bench_memory_budget.py [--memory 366MiB,410MiB] [--data ../shared/data]
        [--dir DIR] [--workers 2] [--cases one-block,ahn,ign]

The epochs, written once into DIR (default a temporary folder; never committed):

- ``ahn``: the AHN3 tile ``ahn3_delft/ahn3_cropped_1.laz`` (640,510 points) against a copy with
  every third point left out and a 40 m square raised by 3 m (an edited, thinner later survey);
- ``ign``: the six IGN LiDAR HD tiles of ``ign_lidarhd_montpellier`` as a set (a folder) against
  a folder of the same tiles each thinned the same way;
- ``crop``: for one block, the largest square of the ``ahn`` pair, from its corner, that the
  change map's own rule (``lidar_sig.change_map``'s estimate of one block, read from the
  package) still keeps in one block at the budget: the worst case of one block.

Cases at each budget: one block (``crop``, no other option) and work units (``ahn`` with
``--workers N``, and ``ign`` as sets with no other option). Every process of the run (the
command's and every worker it starts) is sampled every 0.1 s with psutil; the peak resident set
size of each is printed against the budget, and the line says ``over`` for one above it. The
figures are memory, not times: they may be measured while other work runs.
"""
from __future__ import annotations

import argparse
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import laspy
import numpy as np

MIB = 2**20
#: The edit of the later epoch: a square of this side (metres), raised by RAISE, from the corner
#: of the tile plus OFFSET.
SIDE, RAISE, OFFSET = 40.0, 3.0, 60.0


def thinned_edited(src, dst):
    """Write ``src`` to ``dst`` with every third point left out and a square raised."""
    las = laspy.read(src)
    keep = np.arange(len(las.points)) % 3 != 2
    out = laspy.LasData(las.header)
    out.points = las.points[keep]
    x, y = np.asarray(out.x), np.asarray(out.y)
    x0, y0 = float(las.header.mins[0]) + OFFSET, float(las.header.mins[1]) + OFFSET
    inside = (x >= x0) & (x < x0 + SIDE) & (y >= y0) & (y < y0 + SIDE)
    z = np.asarray(out.z).copy()
    z[inside] += RAISE
    out.z = z
    out.write(dst)


def cropped(src, dst, side):
    """Write the points of ``src`` in the square of ``side`` metres at its lowest corner to ``dst``;
    returns how many."""
    las = laspy.read(src)
    x, y = np.asarray(las.x), np.asarray(las.y)
    x0, y0 = float(las.header.mins[0]), float(las.header.mins[1])
    inside = (x < x0 + side) & (y < y0 + side)
    out = laspy.LasData(las.header)
    out.points = las.points[inside]
    out.write(dst)
    return int(inside.sum())


def one_block_crop(a, b, folder, budget):
    """The ``crop`` pair for ``budget`` bytes: the largest square (by halving steps of its side)
    whose two epochs the package's rule keeps in one block; returns (A, B, points of both)."""
    import lidar_sig as ls
    from lidar_sig.change_map._in_units import in_units

    lo, hi = 1.0, 400.0
    best = None
    for _ in range(14):
        side = (lo + hi) / 2
        ca, cb = folder / f"crop_a_{budget}.laz", folder / f"crop_b_{budget}.laz"
        n = cropped(a, ca, side) + cropped(b, cb, side)
        if in_units([str(ca), str(cb)], ls.Execution(memory=budget), ls.Pipeline(progress=False)) is None:
            best, lo = (side, n), side
        else:
            hi = side
    side, n = best
    cropped(a, ca, side)
    cropped(b, cb, side)
    return ca, cb, n


def sample(cmd, out_dir):
    """Run ``cmd``; (return code, stderr, {pid: (role, peak RSS bytes)}) of every process of its
    tree, sampled every 0.1 s."""
    import psutil

    peaks = {}
    with tempfile.TemporaryFile("w+") as fo, tempfile.TemporaryFile("w+") as fe:
        proc = subprocess.Popen(cmd, stdout=fo, stderr=fe, text=True, cwd=out_dir)
        main = psutil.Process(proc.pid)
        while proc.poll() is None:
            try:
                tree = [main, *main.children(recursive=True)]
            except psutil.Error:
                tree = []
            for p in tree:
                try:
                    rss = p.memory_info().rss
                    role = "main" if p.pid == proc.pid else _role(p.cmdline())
                except psutil.Error:
                    continue
                old = peaks.get(p.pid, (role, 0))
                peaks[p.pid] = (role, max(old[1], rss))
            time.sleep(0.1)
        fe.seek(0)
        err = fe.read()
    return proc.returncode, err, peaks


def _role(cmdline):
    text = " ".join(cmdline)
    if "resource_tracker" in text:
        return "resource tracker"
    if "spawn" in text or "forkserver" in text:
        return "worker"
    return "child"


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--memory", default="366MiB,410MiB")
    parser.add_argument("--data", default=str(Path(__file__).resolve().parents[1].parent / "shared" / "data"))
    parser.add_argument("--dir", default=None)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--cases", default="one-block,ahn,ign", help="of one-block, ahn (work units), ign (work units)")
    args = parser.parse_args()
    from lidar_sig.tiling.memory import budget_bytes

    data = Path(args.data)
    tmp = tempfile.TemporaryDirectory() if args.dir is None else None
    folder = Path(args.dir or tmp.name)
    folder.mkdir(parents=True, exist_ok=True)
    ahn_a = data / "ahn3_delft" / "ahn3_cropped_1.laz"
    ahn_b = folder / "ahn_b.laz"
    if not ahn_b.exists():
        thinned_edited(ahn_a, ahn_b)
    ign_a = data / "ign_lidarhd_montpellier"
    ign_b = folder / "ign_b"
    asked = set(args.cases.split(","))
    if "ign" in asked and not ign_b.exists():
        ign_b.mkdir()
        for f in sorted(ign_a.glob("*.laz")):
            thinned_edited(f, ign_b / f.name)
    print(f"{'budget':>8}  {'case':<44} {'process':<17} {'peak':>9}  within")
    for text in args.memory.split(","):
        budget = budget_bytes(text)
        cases = []
        if "one-block" in asked:
            ca, cb, n_crop = one_block_crop(ahn_a, ahn_b, folder, budget)
            cases.append((f"one block: AHN3 crop ({n_crop:,} points of both)", [ca, cb]))
        if "ahn" in asked:
            cases.append((f"work units: AHN3 tile, --workers {args.workers}",
                          [ahn_a, ahn_b, "--workers", str(args.workers)]))
        if "ign" in asked:
            cases.append(("work units: IGN tiles as sets", [ign_a, ign_b]))
        for label, extra in cases:
            out = folder / "out"
            out.mkdir(exist_ok=True)
            cmd = [sys.executable, "-m", "lidar_sig", "changes", *map(str, extra), "-o", str(out / "map.tif"),
                   "--overwrite", "--memory", text, "-q"]
            code, err, peaks = sample(cmd, out)
            said = re.sub(r"\s+", " ", err.strip())[-300:]
            if code != 0:
                print(f"{text:>8}  {label:<44} failed ({code}): {said}")
                continue
            for pid, (role, peak) in sorted(peaks.items(), key=lambda kv: (kv[1][0] != "main", kv[0])):
                mark = "yes" if peak <= budget else "OVER"
                print(f"{text:>8}  {label:<44} {role + ' ' + str(pid):<17} {peak / MIB:>5.0f} MiB  {mark}")
    if tmp is not None:
        tmp.cleanup()


if __name__ == "__main__":
    main()
