"""The change map's time beside py4dgeo's M3C2 (issue 37, must-show 3): whole processes, reading
included, on pairs with known edits.

    python benchmarks/bench_m3c2_time.py [--runs 3] [--dir DIR]

Pairs (written once in DIR, default a temporary folder):

- AHN3: ../shared/data/ahn3_delft/ahn3_cropped_1.laz against its edited copy
  (benchmarks/edited_epoch.py: a building removed, vegetation removed, a box building added, 80%
  of the points kept, moved by (0.3, -0.2, 0.05) m; AHN3 keeps vegetation in class 1);
- IGN: the six IGN LiDAR HD tiles (a folder) against the block's edited copy (one file).

Per pair and round, alternating which goes first: ``python -m lidar_sig changes A B -o map.tif``
with its defaults (then once more, untimed, with ``--json`` for the edits found), and ``python bench_m3c2_time.py --m3c2 A B OUT`` (M3C2 as
benchmarks/change_power.py sets it: core points at most one per m² of A, cylinder and normal
radius max(1 m, sqrt(10 / (pi density))), 15 m long, no registration error; py4dgeo's own
threads; the distances, their level of detection and the core points written to an .npz). The
medians of ``--runs`` rounds and their ratio are printed; the change map's edits found are
checked from its JSON. Run it on an idle machine: both tools use every core.
"""
from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
DATA = HERE.parents[1] / "shared" / "data"
AHN3 = DATA / "ahn3_delft" / "ahn3_cropped_1.laz"
IGN = DATA / "ign_lidarhd_montpellier"


def read_xyz(source):
    """(N, 3) coordinates of a LAS/LAZ file or of a folder's tiles joined."""
    import laspy

    paths = sorted(Path(source).glob("*.la[sz]")) if Path(source).is_dir() else [Path(source)]
    parts = []
    for p in paths:
        las = laspy.read(p)
        parts.append(np.column_stack([las.x, las.y, las.z]))
    return np.vstack(parts)


def m3c2(a_path, b_path, out):
    """M3C2 from A to B as benchmarks/change_power.py runs it, from the files to an .npz."""
    import logging
    import os

    import py4dgeo

    py4dgeo.set_py4dgeo_logfile(os.devnull)
    logging.getLogger("py4dgeo").setLevel(logging.WARNING)
    a, b = read_xyz(a_path), read_xyz(b_path)
    # points per m² over the occupied 10 m pixels, each pixel an int64 key: np.unique over rows
    # (axis=0) took 1 s of the AHN3 pair where a 1-D unique takes 0.05 s, set-up M3C2 does not need
    ij = np.floor((a[:, :2] - a[:, :2].min(axis=0)) / 10.0).astype(np.int64)
    pixels = np.unique(ij[:, 0] * (int(ij[:, 1].max()) + 1) + ij[:, 1])
    density = len(a) / (len(pixels) * 100.0)
    core = a[np.random.default_rng(0).random(len(a)) < min(1.0, 1.0 / density)]
    radius = max(1.0, float(np.sqrt(10.0 / (np.pi * density))))
    run = py4dgeo.M3C2(epochs=(py4dgeo.Epoch(a), py4dgeo.Epoch(b)), corepoints=core, cyl_radius=radius,
                       normal_radii=(radius,), max_distance=15.0, registration_error=0.0)
    distances, uncertainties = run.run()
    np.savez(out, core=core, distances=distances, lod=uncertainties["lodetection"])


def pairs(folder):
    """{name: (A, B, edits)}: the pairs, written once into ``folder``."""
    import lidar_sig as ls
    from edited_epoch import edit, write_las
    from lidar_sig.change_map import read_epoch

    out = {}
    for name, source, vegetation in (("AHN3", AHN3, 1), ("IGN", IGN, 5)):
        b = folder / f"{name.lower()}_b.laz"
        edits_file = folder / f"{name.lower()}_edits.json"
        if not b.is_file():
            one = ls.read(source) if source.is_file() else read_epoch(source)
            two, edits = edit(one, vegetation=vegetation)
            write_las(two, b)
            edits_file.write_text(json.dumps({k: [float(v) for v in c] for k, c in edits.items()}))
        out[name] = (source, b, json.loads(edits_file.read_text()))
    return out


def timed(command, cwd):
    start = time.perf_counter()
    done = subprocess.run(command, cwd=cwd, capture_output=True, text=True)
    if done.returncode != 0:
        raise RuntimeError(f"{command} failed:\n{done.stderr[-2000:]}")
    return time.perf_counter() - start, done.stdout


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=3)
    parser.add_argument("--dir", default=None)
    parser.add_argument("--m3c2", nargs=3, metavar=("A", "B", "OUT"), help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.m3c2:
        m3c2(*args.m3c2)
        return
    folder = Path(args.dir or tempfile.mkdtemp(prefix="bench-m3c2-"))
    folder.mkdir(parents=True, exist_ok=True)
    print(f"{'pair':<6} {'change map s':>13} {'M3C2 s':>8} {'ratio':>6}  edits found (change map)")
    for name, (a, b, edits) in pairs(folder).items():
        cm_cmd = [sys.executable, "-m", "lidar_sig", "changes", str(a), str(b), "-o", str(folder / f"{name}.tif"),
                  "--overwrite"]
        m3_cmd = [sys.executable, str(Path(__file__).resolve()), "--m3c2", str(a), str(b), str(folder / f"{name}.npz")]
        times = {"cm": [], "m3c2": []}
        for r in range(args.runs):
            order = (("cm", cm_cmd), ("m3c2", m3_cmd)) if r % 2 == 0 else (("m3c2", m3_cmd), ("cm", cm_cmd))
            for key, cmd in order:
                times[key].append(timed(cmd, folder)[0])
        report = json.loads(timed(cm_cmd + ["--json", "--top", "100000"], folder)[1])  # untimed: the edits found
        significant = {(round(c["bounds"][0]), round(c["bounds"][1])) for c in report["top"] if c["significant"]}
        hits = sum((round(x - 12.5), round(y - 12.5)) in significant for x, y in edits.values())
        cm_s, m3_s = statistics.median(times["cm"]), statistics.median(times["m3c2"])
        print(f"{name:<6} {cm_s:>13.2f} {m3_s:>8.2f} {cm_s / m3_s:>6.2f}  {hits} of {len(edits)}   "
              f"(rounds: change map {', '.join(f'{t:.2f}' for t in times['cm'])}; "
              f"M3C2 {', '.join(f'{t:.2f}' for t in times['m3c2'])})", flush=True)


if __name__ == "__main__":
    main()
