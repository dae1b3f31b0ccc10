"""The change map at survey scale (issue 37): one command on two synthetic epochs of a given size,
its peak memory per process, its time per point, and the known edits it finds.

    python benchmarks/bench_change_scale.py [--sizes 1000000,20000000] [--density 20] [--dir DIR]
        [--memory SIZE] [--m3c2] [--runs N]

For each size, epoch A is the LAZ file of benchmarks/bench_tiles.py (blocks of one million points
of an airborne-like scene side by side, 20 points/m² by default) and epoch B a copy of it written
chunk by chunk with known edits, then a uniform 80% of its points kept:

- in every fifth block of scene, two 20 m squares inside two 25 m cells of the grid aligned to
  multiples of 25 m: one raised by 4 m (a storey added), one whose points all become class 6
  (ground built over, the heights kept).

Then ``lidar-sig changes A B -o map.tif --cells cells.gpkg --points b.laz --json`` with no other
option (``--memory`` passed on when given) runs as one process tree sampled every 0.1 s: the peak
resident set size of the main process and of the largest worker, wall seconds, microseconds per
point of both epochs and that figure relative to the smallest size's (the issue's bound: 1.2),
the work units and the edited cells found (changed) out of those edited.

With ``--m3c2``, py4dgeo's M3C2 runs on the same two files in the same run, as
benchmarks/bench_m3c2_time.py runs it (a whole process: reading, core points at most one per m²
of A, its distances and levels written to an .npz), sampled the same way, and the change map's
time over M3C2's is printed; with ``--runs N`` both run N times, alternating which goes first,
and the medians are printed. The generated files are kept in ``--dir`` between runs.
"""
from __future__ import annotations

import argparse
import json
import statistics
import sys
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_tiles import BLOCK, DENSITY, make_laz, measure  # noqa: E402

CELL = 25.0
#: The edits' squares: offset and side inside their 25 m cell (metres), and every how many blocks.
EDIT_OFFSET, EDIT_SIDE, EDIT_EVERY = 2.5, 20.0, 5
RAISE = 4.0
KEEP = 0.8


def edit_squares(n, density=DENSITY):
    """[(kind, x0, y0)] of the edited squares of a file of ``n`` points made by make_laz: the
    lower-left corners, in the CRS, of 20 m squares inside 25 m cells of the aligned grid."""
    blocks = max(1, n // BLOCK)
    per_row = int(np.ceil(np.sqrt(blocks)))
    side = np.sqrt(BLOCK / density)
    squares = []
    for b in range(0, blocks, EDIT_EVERY):
        bx, by = 500_000.0 + (b % per_row) * side, 6_000_000.0 + (b // per_row) * side
        for kind, (cx, cy) in (("raised", (0.3, 0.3)), ("built over", (0.6, 0.6))):
            x0 = np.floor((bx + cx * side) / CELL) * CELL + EDIT_OFFSET
            y0 = np.floor((by + cy * side) / CELL) * CELL + EDIT_OFFSET
            squares.append((kind, float(x0), float(y0)))
    return squares


def make_edited(src, dst, squares, seed=5):
    """Write ``dst``: ``src`` with the edits of ``squares`` and a uniform 80% of its points kept,
    chunk by chunk."""
    import laspy

    rng = np.random.default_rng(seed)
    with laspy.open(src) as reader, laspy.open(dst, mode="w", header=reader.header) as writer:
        for chunk in reader.chunk_iterator(BLOCK):
            x, y = np.asarray(chunk.x), np.asarray(chunk.y)
            z, cls = np.asarray(chunk.z).copy(), np.asarray(chunk.classification).copy()
            for kind, x0, y0 in squares:
                inside = (x >= x0) & (x < x0 + EDIT_SIDE) & (y >= y0) & (y < y0 + EDIT_SIDE)
                if kind == "raised":
                    z[inside] += RAISE
                else:
                    cls[inside] = 6
            chunk.z, chunk.classification = z, cls
            writer.write_points(chunk[rng.random(len(chunk)) < KEEP])


def found(report, squares):
    """Edited cells that the map calls changed, from its JSON (every compared cell listed)."""
    changed = {(round(c["bounds"][0]), round(c["bounds"][1])) for c in report["top"] if c["significant"]}
    cells = {(round(x0 - EDIT_OFFSET), round(y0 - EDIT_OFFSET)) for _, x0, y0 in squares}
    return len(cells & changed), len(cells)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", default="1000000,20000000", help="points per epoch, comma-separated")
    parser.add_argument("--density", type=float, default=DENSITY)
    parser.add_argument("--dir", default=None, help="folder for the generated files (default: a temporary one)")
    parser.add_argument("--memory", default=None, help="--memory passed on to the command")
    parser.add_argument("--m3c2", action="store_true", help="time M3C2 on the same files in the same run")
    parser.add_argument("--runs", type=int, default=1, help="runs of each tool, alternating (medians printed)")
    args = parser.parse_args()
    folder = Path(args.dir or tempfile.mkdtemp(prefix="bench-change-scale-"))
    folder.mkdir(parents=True, exist_ok=True)
    base = None
    print(f"{'points/epoch':>13} {'wall s':>8} {'us/point':>9} {'ratio':>6} {'main MiB':>9} {'worker MiB':>11} "
          f"{'units':>6} {'edits found':>12}" + (f" {'M3C2 s':>8} {'M3C2 MiB':>9} {'map/M3C2':>9}" if args.m3c2 else ""))
    for n in (int(s) for s in args.sizes.split(",")):
        a, b = folder / f"a_{n}.laz", folder / f"b_{n}.laz"
        squares = edit_squares(n, args.density)
        if not a.is_file():
            make_laz(a, n, args.density)
        if not b.is_file():
            make_edited(a, b, squares)
        out = folder / f"out_{n}"
        out.mkdir(exist_ok=True)
        cmd = ["changes", a, b, "-o", out / "map.tif", "--cells", out / "cells.gpkg", "--points", out / "b.laz",
               "--json", "--top", "100000", "--overwrite"] + (["--memory", args.memory] if args.memory else [])
        m3c2_cmd = [sys.executable, str(Path(__file__).resolve().parent / "bench_m3c2_time.py"), "--m3c2", str(a),
                    str(b), str(out / "m3c2.npz")]
        walls, m3c2 = [], []
        for r in range(args.runs):  # alternating which goes first
            if args.m3c2 and r % 2:
                m3c2.append(measure(None, command=m3c2_cmd))
            wall, main_mib, worker_mib, stdout = measure(cmd)
            walls.append(wall)
            if args.m3c2 and not r % 2:
                m3c2.append(measure(None, command=m3c2_cmd))
        wall = statistics.median(walls)
        report = json.loads(stdout)
        us = wall / (2 * n) * 1e6
        base = base or us
        hits, edited = found(report, squares)
        units = (report.get("work_units") or {}).get("units", "-")
        line = (f"{n:>13,} {wall:>8.1f} {us:>9.3f} {us / base:>6.2f} {main_mib:>9.0f} {worker_mib:>11.0f} {units!s:>6} "
                f"{hits:>5} of {edited:<5}")
        if args.m3c2:
            m3c2_wall = statistics.median(w for w, *_ in m3c2)
            m3c2_mib = max(max(main, other) for _, main, other, _ in m3c2)
            line += f" {m3c2_wall:>8.1f} {m3c2_mib:>9.0f} {wall / m3c2_wall:>9.2f}"
        print(line, flush=True)


if __name__ == "__main__":
    main()
