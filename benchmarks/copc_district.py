"""A district of a large synthetic delivery mapped with an area of interest (docs/scale-out.md,
"An area of interest": measured).

Writes two epochs of a synthetic delivery as COPC files with copclib (the writer made for
COPC: ``pip install copclib``; the benchmark's own need, not lidar_sig's), each of ``--points``
points (default 20 million, 5 points/m² over a square of 2 km), B edited inside the district (a
box building added on bare ground), then runs

    lidar-sig changes A.copc.laz B.copc.laz --aoi DISTRICT --cells cells.gpkg --json

and reports its time and the bytes it read, against the bytes of the two whole files (what any
run without an area reads: every point) and the time of reading every point of both once (the
least a run of the whole delivery spends before it computes anything). With ``--http`` the same
district is mapped from a local web server by range requests (bytes fetched counted by the
server). Times are wall seconds on this machine; the district run and the whole reading are run
alternately, ``--repeats`` times each.

    python benchmarks/copc_district.py --out /tmp/copc_bench
"""
from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

DENSITY = 5.0  # points per m²
LEAF_POINTS = 5000  # points of a leaf node, about: the depth of the leaves follows (6 for 20 million points)
SCALE = 0.01


def terrain(x, y):
    """Ground height (m): rolling hills."""
    return 40.0 + 6.0 * np.sin(x / 90.0) * np.cos(y / 130.0) + 2.0 * np.sin((x + y) / 37.0)


def cell_points(rng, x0, y0, side, n, edit):
    """(x, y, z, class) of ``n`` points, uniform over the columns of side ``side`` from ``x0``,
    ``y0`` (arrays, one value a point): ground, houses (class 6) on a grid
    of 60 m, trees (class 5); ``edit`` (x0, y0, x1, y1): a box building 9 m high added there."""
    x = x0 + side * rng.random(n)
    y = y0 + side * rng.random(n)
    z = terrain(x, y) + 0.03 * rng.standard_normal(n)
    cls = np.full(n, 2, np.uint8)
    gx, gy = np.mod(x, 60.0), np.mod(y, 60.0)
    house = (gx > 10) & (gx < 28) & (gy > 12) & (gy < 26)
    z[house] += 7.0 + 0.3 * np.abs(gx[house] - 19.0)
    cls[house] = 6
    tree = ~house & (np.hypot(gx - 45.0, gy - 45.0) < 4.0)
    z[tree] += 4.0 + 6.0 * rng.random(int(tree.sum()))
    cls[tree] = 5
    if edit is not None:
        box = (x >= edit[0]) & (x <= edit[2]) & (y >= edit[1]) & (y <= edit[3]) & (cls == 2)
        z[box] += 9.0
        cls[box] = 6
    return x, y, z, cls


def write_copc(path, n_points, seed, edit=None):
    """A COPC file of about ``n_points`` points over a square at DENSITY, its octree filled
    level by level (each point's level drawn so that every level is a thinner copy of the next)."""
    import copclib as copc
    import laspy

    side = float(np.sqrt(n_points / DENSITY))
    depth = int(np.clip(round(np.log(n_points / LEAF_POINTS) / np.log(4)), 1, 8))
    columns = 2**depth
    column = side / columns
    half = side / 2.0
    cfg = copc.CopcConfigWriter(6, copc.Vector3(SCALE, SCALE, SCALE), copc.Vector3(0.0, 0.0, 0.0),
                                _lambert93_wkt())
    info = cfg.copc_info
    info.center_x, info.center_y, info.center_z, info.halfsize = half, half, half, half
    info.spacing = side / 128.0
    header = laspy.LasHeader(point_format=6, version="1.4")
    header.scales, header.offsets = np.array([SCALE] * 3), np.zeros(3)
    levels = 4.0 ** np.arange(depth + 1)
    levels /= levels.sum()
    upper: dict[tuple, list] = {}
    writer = copc.FileWriter(str(path), cfg)
    lo, hi = np.full(3, np.inf), np.full(3, -np.inf)
    per_column = int(round(n_points / columns**2))
    block = min(8, columns)  # columns a side generated and filed together
    for bi in range(0, columns, block):
        for bj in range(0, columns, block):
            rng = np.random.default_rng([seed, bi, bj])
            ci = np.repeat(np.arange(bi, bi + block), block * per_column)
            cj = np.tile(np.repeat(np.arange(bj, bj + block), per_column), block)
            x, y, z, cls = cell_points(rng, ci * column, cj * column, column, len(ci), edit)
            lo = np.minimum(lo, [x.min(), y.min(), z.min()])
            hi = np.maximum(hi, [x.max(), y.max(), z.max()])
            d = rng.choice(depth + 1, size=len(x), p=levels)
            keys = np.column_stack([d, ci >> (depth - d), cj >> (depth - d),
                                    np.floor(z / (side / 2.0**d)).astype(np.int64)])
            order = np.lexsort(keys.T[::-1])
            keys, records = keys[order], _records(header, x[order], y[order], z[order], cls[order])
            breaks = np.flatnonzero(np.any(np.diff(keys, axis=0) != 0, axis=1)) + 1
            for a, b in zip(np.r_[0, breaks], np.r_[breaks, len(keys)]):
                key = tuple(int(v) for v in keys[a])
                if key[0] == depth:  # a leaf: complete once its block is
                    writer.AddNode(copc.VoxelKey(*key), copc.VectorChar(records[a:b].view(np.int8).ravel()))
                else:
                    upper.setdefault(key, []).append(records[a:b])
    for key, parts in upper.items():
        writer.AddNode(copc.VoxelKey(*key), copc.VectorChar(np.concatenate(parts).view(np.int8).ravel()))
    writer.copc_config.las_header.min = copc.Vector3(*lo)
    writer.copc_config.las_header.max = copc.Vector3(*hi)
    writer.Close()
    return side


def _records(header, x, y, z, cls):
    """Raw point format 6 records (a structured array; as int8 bytes copclib takes them)."""
    import laspy

    pts = laspy.ScaleAwarePointRecord.zeros(len(x), header=header)
    pts.x, pts.y, pts.z = x, y, z
    pts.classification = cls
    pts.return_number = np.ones(len(x), np.uint8)
    pts.number_of_returns = np.ones(len(x), np.uint8)
    return pts.array


def _lambert93_wkt():
    import pyproj

    return pyproj.CRS("EPSG:2154").to_wkt()


def read_whole(paths):
    """Every point of ``paths`` read once, in chunks (what a run without an area starts with)."""
    import laspy

    n = 0
    for p in paths:
        with laspy.open(p) as reader:
            for chunk in reader.chunk_iterator(1_000_000):
                n += len(chunk)
    return n


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", type=Path, required=True, help="folder for the deliveries and outputs")
    ap.add_argument("--points", type=float, default=20e6, help="points per epoch")
    ap.add_argument("--district", type=float, default=250.0, help="side of the district (m)")
    ap.add_argument("--repeats", type=int, default=2)
    ap.add_argument("--http", action="store_true", help="also map the district from a local web server")
    args = ap.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    side = float(np.sqrt(args.points / DENSITY))
    mid = side / 2.0
    district = (mid - args.district / 2, mid - args.district / 2, mid + args.district / 2, mid + args.district / 2)
    edit = (mid - 20.0, mid - 20.0, mid + 5.0, mid + 5.0)
    paths = [args.out / "delivery_a.copc.laz", args.out / "delivery_b.copc.laz"]
    for path, e in zip(paths, (None, edit)):
        if not path.exists():
            t = time.perf_counter()
            write_copc(path, int(args.points), seed=1, edit=e)
            print(f"wrote {path.name} in {time.perf_counter() - t:.1f} s", file=sys.stderr)
    import laspy

    counts = [laspy.open(p).header.point_count for p in paths]
    sizes = [p.stat().st_size for p in paths]
    aoi = ",".join(f"{v:.2f}" for v in district)
    runs, wholes = [], []
    for r in range(args.repeats):
        cells = args.out / "cells.gpkg"
        cmd = [sys.executable, "-m", "lidar_sig", "changes", *map(str, paths), "--aoi", aoi, "--cells", str(cells),
               "--overwrite", "--json", "--workers", "1"]
        t = time.perf_counter()
        done = subprocess.run(cmd, capture_output=True, text=True, check=True)
        runs.append(time.perf_counter() - t)
        result = json.loads(done.stdout)
        t = time.perf_counter()
        read_whole(paths)
        wholes.append(time.perf_counter() - t)
    read = result["aoi"]
    out = {"points_per_epoch": counts, "file_bytes": sizes, "district": aoi, "district_points": read["points_kept"],
           "district_points_read": read["points_read"], "copc_nodes": read["copc_nodes"],
           "bytes_read": read["bytes_read"], "share_of_bytes": read["bytes_read"] / sum(sizes),
           "district_run_s": runs, "whole_read_s": wholes,
           "significant_cells": result["grid"]["significant"], "compared_cells": result["grid"]["valid"]}
    if args.http:
        out.update(_over_http(paths, aoi, args.out))
    print(json.dumps(out, indent=1))


def _over_http(paths, aoi, folder):
    """The district mapped from a local web server; the bytes the server sent."""
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
    from test_aoi import _Server

    server = _Server(paths[0].parent)
    try:
        urls = [f"{server.url}/{p.name}" for p in paths]
        t = time.perf_counter()
        done = subprocess.run([sys.executable, "-m", "lidar_sig", "changes", *urls, "--aoi", aoi, "--json",
                               "--workers", "1"], capture_output=True, text=True, check=True)
        seconds = time.perf_counter() - t
    finally:
        server.close()
    return {"http_bytes_sent": server.sent, "http_bytes_fetched": json.loads(done.stdout)["aoi"]["bytes_fetched"],
            "http_run_s": seconds}


if __name__ == "__main__":
    main()
