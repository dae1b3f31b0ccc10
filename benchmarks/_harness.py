"""Shared helpers of the benchmark scripts: child processes, peak memory, medians.

Each measured run is a separate Python process, so that its peak resident set size (from the
kernel's accounting of the finished child, ``os.wait4``) belongs to that run alone. The child
reports its own compute time, excluding interpreter start-up and file reading, which both
tools share.
"""
from __future__ import annotations

import json
import os
import subprocess
import sys
import time

import numpy as np


def run_child(args, timeout=1800, python=True):
    """Run ``python args`` (or the command ``args``) and return (its last JSON line on stdout,
    or the wall seconds when it prints none; peak RSS in MiB)."""
    cmd = [sys.executable, *args] if python else list(args)
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    start = time.monotonic()
    _, status, usage = os.wait4(proc.pid, 0)
    out, err = proc.stdout.read(), proc.stderr.read()  # small outputs: no pipe can fill
    proc.stdout.close()
    proc.stderr.close()
    proc.returncode = os.waitstatus_to_exitcode(status)
    if proc.returncode != 0 or time.monotonic() - start > timeout:
        raise RuntimeError(f"benchmark child {args} failed ({proc.returncode}):\n{err[-2000:]}")
    wall = time.monotonic() - start
    lines = [ln for ln in out.splitlines() if ln.startswith("{")]
    result = json.loads(lines[-1]) if lines else wall
    return result, usage.ru_maxrss / 1024.0  # Linux reports KiB


def alternate(script, file, cases, runs):
    """Run ``script file --worker CASE`` for every case, ``runs`` rounds, the cases alternating.

    Returns ({case: [seconds]}, {case: [peak MiB]}, points) from the children's reports.
    """
    times = {c: [] for c in cases}
    mem = {c: [] for c in cases}
    out = {}
    for _ in range(runs):
        for case in cases:
            out, rss = run_child([script, file, "--worker", case])
            times[case].append(out["seconds"])
            mem[case].append(rss)
    return times, mem, out.get("points")


def file_runs_args(doc):
    """Arguments every per-file benchmark takes: FILE, --runs, and the hidden --worker."""
    import argparse

    parser = argparse.ArgumentParser(description=doc, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("file")
    parser.add_argument("--runs", type=int, default=3)
    parser.add_argument("--worker", help=argparse.SUPPRESS)
    return parser.parse_args()


def lidar_sig_command():
    """The `lidar-sig` command of this Python: the script beside its interpreter (a virtual
    environment that is not activated), else the one on PATH."""
    import shutil
    from pathlib import Path

    beside = Path(sys.executable).with_name("lidar-sig")
    exe = str(beside) if beside.is_file() else shutil.which("lidar-sig")
    if exe is None:
        sys.exit(f"lidar-sig is neither beside {sys.executable} nor on PATH: install the package first "
                 "(pip install -e .)")
    return exe


def cli_runs(file, variants, runs):
    """Median-ready wall times and peak RSS of `lidar-sig saliency FILE` per variant.

    ``variants`` maps a label to extra command-line arguments; one warm-up run each (file
    cache, compiled kernels), then ``runs`` rounds with the variants alternating.
    Returns ({label: [seconds]}, {label: [MiB]}).
    """
    import tempfile
    from pathlib import Path

    exe = lidar_sig_command()
    walls = {v: [] for v in variants}
    mem = {v: [] for v in variants}
    with tempfile.TemporaryDirectory() as tmp:
        base = [exe, "saliency", file, "-o", str(Path(tmp) / "out.laz"), "--overwrite", "-q"]
        for extra in variants.values():
            run_child(base + list(extra), python=False)
        for _ in range(runs):
            for label, extra in variants.items():
                wall, rss = run_child(base + list(extra), python=False)
                walls[label].append(wall)
                mem[label].append(rss)
    return walls, mem


def report(payload):
    """Child side: print the one JSON line the parent reads."""
    print(json.dumps(payload), flush=True)


def median(values):
    return float(np.median(values))


def read_xyz(path):
    """Coordinates of a LAS/LAZ file as float64, centred on the bounding box."""
    import laspy

    las = laspy.read(path)
    xyz = np.column_stack([las.x, las.y, las.z])
    return xyz - (xyz.min(axis=0) + xyz.max(axis=0)) / 2.0


def table(rows, header):
    """Print rows as an aligned plain-text table."""
    widths = [max(len(str(r[i])) for r in [header] + rows) for i in range(len(header))]
    for r in [header] + rows:
        print("  ".join(str(v).rjust(w) for v, w in zip(r, widths)))


def warm_up(descriptors=("c3dcm",)):
    """Compile (or load from the cache) lidar_sig's kernels on a small random cloud, so that
    timings measure the work and not the compiler."""
    import lidar_sig as ls

    xyz = np.random.default_rng(0).uniform(0, 5, (3000, 3))
    for descriptor in descriptors:
        for strategy, scales in (("multiscale", ls.radii(1.0, units="metric")), ("optimal", ls.knn(10, 20))):
            ls.Pipeline(descriptor=descriptor, strategy=strategy, scales=scales,
                        progress=False).saliency(ls.PointCloud(xyz))
