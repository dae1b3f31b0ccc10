"""Cost of a survey catalogue of many tiles (issue 19, must-show 3): `similar` and `outliers` on a
generated survey of 1,000 small synthetic tiles.

The survey is a grid of square tiles of 40 m in Lambert-93, each a small airborne scene (bumpy
ground, box buildings with flat or pitched roofs, trees as blobs of points) of ``--points``
points, its land changing smoothly across the survey (town in one corner, woods in another) and
drawn at random per tile. A few tiles are spoilt as a delivery's faults would be: every class
code set to 1 ("unclassified"), a fifth of the points added as scattered noise in the air
(another sensor's noise), or the buildings' points classed as ground (half the buildings missing
from the classification). The tiles are written as LAZ in ``--folder`` and catalogued with
`lidar-sig catalog` (an existing catalogue there is reused: it grows by nothing).

Then, timed: in this process, opening the catalogue and asking `similar` (for ``--queries``
tiles, the median and the slowest) and `outliers`; end to end through the command line (the
interpreter's start and imports included), `lidar-sig similar` and `lidar-sig outliers`. The
shortlist is checked against the full metrics of every tile for ``--check`` queries: the top 10
must be the same. The ranks the spoilt tiles get in `outliers` are printed.

    python benchmarks/catalog_scale.py [--tiles 1000] [--points 2500] [--folder DIR] [--workers N]
"""
from __future__ import annotations

import argparse
import json
import math
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
SIDE = 40.0  # metres
ORIGIN = (700000.0, 6600000.0)
#: Spoilt tiles: kind -> how many (at tiles spread over the survey).
SPOILT = {"unclassified": 3, "noise": 2, "no buildings": 2}


def land(i, j, cols, rows):
    """(building share, tree share) of the tile at column i, row j: town towards (0, 0), woods
    towards the opposite corner, a smooth field plus per-tile noise."""
    u, v = i / max(cols - 1, 1), j / max(rows - 1, 1)
    town = 0.45 * math.exp(-((u ** 2 + v ** 2) / 0.35))
    woods = 0.5 * math.exp(-(((1 - u) ** 2 + (1 - v) ** 2) / 0.4))
    return town, woods


def scene(n, town, woods, rng):
    """(xyz (n, 3) in metres within the tile, ASPRS labels): ground 2, buildings 6, trees 5."""
    town = float(np.clip(town + rng.normal(0, 0.04), 0.0, 0.6))
    woods = float(np.clip(woods + rng.normal(0, 0.04), 0.0, 0.6))
    n_roof, n_tree = int(n * town), int(n * woods)
    n_ground = n - n_roof - n_tree
    g = rng.uniform(0, SIDE, (n_ground, 2))
    ground = np.column_stack([g, 0.4 * np.sin(g[:, 0] / 7 + rng.uniform(0, 6)) + 0.03 * rng.standard_normal(n_ground)])
    parts, labels = [ground], [np.full(n_ground, 2)]
    if n_roof:
        k = int(rng.integers(1, 4))
        which = rng.integers(0, k, n_roof)
        centres = rng.uniform(8, SIDE - 8, (k, 2))
        size = rng.uniform(4, 8, (k, 2))
        pitched = rng.random(k) < 0.5
        xy = centres[which] + rng.uniform(-1, 1, (n_roof, 2)) * size[which]
        height = rng.uniform(6, 15, k)[which]
        z = height + np.where(pitched[which], 0.5 * (size[which, 0] - np.abs(xy[:, 0] - centres[which, 0])), 0.0)
        parts.append(np.column_stack([xy, z + 0.03 * rng.standard_normal(n_roof)]))
        labels.append(np.full(n_roof, 6))
    if n_tree:
        k = int(rng.integers(2, 8))
        which = rng.integers(0, k, n_tree)
        centres = np.column_stack([rng.uniform(3, SIDE - 3, (k, 2)), rng.uniform(5, 12, k)])
        parts.append(centres[which] + rng.normal(0, 1.0, (n_tree, 3)) * rng.uniform(1.0, 2.5, k)[which, None])
        labels.append(np.full(n_tree, 5))
    return np.vstack(parts), np.concatenate(labels)


def spoil(kind, xyz, labels, rng):
    if kind == "unclassified":
        return xyz, np.ones_like(labels)
    if kind == "noise":
        m = len(xyz) // 5
        noise = np.column_stack([rng.uniform(0, SIDE, (m, 2)), rng.uniform(-5, 40, m)])
        return np.vstack([xyz, noise]), np.concatenate([labels, np.ones(m, labels.dtype)])
    if kind == "no buildings":
        return xyz, np.where(labels == 6, 2, labels)
    raise ValueError(kind)


def make_survey(folder, n_tiles, points, seed=0):
    """Write the survey's tiles (LAZ) in ``folder``; returns {tile name: spoilt kind}."""
    import laspy
    import pyproj

    cols = math.ceil(math.sqrt(n_tiles * 1.5))
    rows = math.ceil(n_tiles / cols)
    rng = np.random.default_rng(seed)
    places = [(i, j) for j in range(rows) for i in range(cols)][:n_tiles]
    spoilt_at = {}
    picks = rng.choice(len(places), sum(SPOILT.values()), replace=False)
    kinds = [k for k, c in SPOILT.items() for _ in range(c)]
    for p, kind in zip(picks, kinds):
        spoilt_at[int(p)] = kind
    crs = pyproj.CRS.from_epsg(2154)
    truth = {}
    for p, (i, j) in enumerate(places):
        name = f"tile_{i:03d}_{j:03d}.laz"
        tile_rng = np.random.default_rng([seed, i, j])
        xyz, labels = scene(points, *land(i, j, cols, rows), tile_rng)
        if p in spoilt_at:
            xyz, labels = spoil(spoilt_at[p], xyz, labels, tile_rng)
            truth[name] = spoilt_at[p]
        xyz = xyz + [ORIGIN[0] + i * SIDE, ORIGIN[1] + j * SIDE, 40.0]
        header = laspy.LasHeader(point_format=6, version="1.4")
        header.scales, header.offsets = [0.01] * 3, np.floor(xyz.min(axis=0))
        header.add_crs(crs)
        las = laspy.LasData(header)
        las.x, las.y, las.z = xyz.T
        las.classification = labels
        las.write(folder / name)
    return truth


def cli(*args):
    """Wall seconds and stdout of `lidar-sig ARGS` (a new process: start-up and imports included)."""
    start = time.perf_counter()
    done = subprocess.run([sys.executable, "-m", "lidar_sig", *map(str, args)], capture_output=True, text=True,
                          env={**os.environ, "PYTHONPATH": str(ROOT)})
    if done.returncode != 0:
        sys.exit(f"lidar-sig {' '.join(map(str, args))} failed:\n{done.stderr[-2000:]}")
    return time.perf_counter() - start, done.stdout


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--tiles", type=int, default=1000)
    parser.add_argument("--points", type=int, default=2500, help="points per tile")
    parser.add_argument("--folder", default=None, help="where the tiles and the catalogue go (kept) [a temporary one]")
    parser.add_argument("--workers", type=int, default=None, help="for `lidar-sig catalog` [all cores]")
    parser.add_argument("--queries", type=int, default=20, help="similar queries timed in this process")
    parser.add_argument("--check", type=int, default=5, help="queries checked against every tile's full metrics")
    parser.add_argument("--json", default=None, help="also write the figures to this JSON file")
    args = parser.parse_args()
    import lidar_sig as ls

    tmp = None
    if args.folder is None:
        tmp = tempfile.TemporaryDirectory(prefix="lidar-sig-catalog-")
        args.folder = tmp.name
    folder = Path(args.folder)
    tiles = folder / "tiles"
    catalogue = folder / "survey.h5"
    truth_file = folder / "spoilt.json"
    out = {"tiles": args.tiles, "points_per_tile": args.points, "load_before": os.getloadavg()[0]}
    if not truth_file.exists() or len(list(tiles.glob("*.laz"))) != args.tiles:
        tiles.mkdir(parents=True, exist_ok=True)
        start = time.perf_counter()
        truth = make_survey(tiles, args.tiles, args.points)
        truth_file.write_text(json.dumps(truth))
        print(f"generated {args.tiles:,} tiles of {args.points:,} points in {time.perf_counter() - start:.1f} s")
    truth = json.loads(truth_file.read_text())
    workers = ["--workers", str(args.workers)] if args.workers else []
    seconds, text = cli("catalog", tiles, "-o", catalogue, "-q", *workers)
    out["catalog_seconds"] = seconds
    out["catalog_mib"] = catalogue.stat().st_size / 2 ** 20
    print(f"lidar-sig catalog: {seconds:.1f} s ({seconds / args.tiles * 1000:.0f} ms a tile end to end, "
          f"{'grown by nothing: tiles already in' if seconds < args.tiles * 0.05 else 'computed'}); "
          f"catalogue {out['catalog_mib']:.1f} MiB")

    # in this process: a warm-up (imports), then each query with the catalogue opened afresh
    names = ls.Catalog(catalogue).names
    ls.Catalog(catalogue).similar(names[0])
    rng = np.random.default_rng(1)
    queries = [names[k] for k in rng.choice(len(names), min(args.queries, len(names)), replace=False)]
    times, certain = [], 0
    for q in queries:
        start = time.perf_counter()
        found = ls.Catalog(catalogue).similar(q, top=10)
        times.append(time.perf_counter() - start)
        certain += found.shortlist["certain"]
    out["similar_seconds_median"] = float(np.median(times))
    out["similar_seconds_max"] = float(np.max(times))
    out["similar_shortlist"] = found.shortlist["size"]
    print(f"similar (top 10, shortlist {found.shortlist['size']}), in process, catalogue opened each time: "
          f"median {np.median(times):.3f} s, slowest {np.max(times):.3f} s over {len(times)} queries; "
          f"certain by the bound for {certain} of {len(times)}")
    start = time.perf_counter()
    cat = ls.Catalog(catalogue)
    found = cat.outliers()
    out["outliers_seconds"] = time.perf_counter() - start
    print(f"outliers, in process, catalogue opened: {out['outliers_seconds']:.3f} s")
    ranks = {r["name"]: r["rank"] for r in found.results}
    spoilt = sorted((ranks[name], name, kind) for name, kind in truth.items())
    out["spoilt_ranks"] = {name: rank for rank, name, _ in spoilt}
    print("spoilt tiles' ranks in outliers: " + ", ".join(f"{kind} {rank}" for rank, _, kind in spoilt))

    # end to end through the command line
    walls = [cli("similar", q, catalogue, "--top", "10")[0] for q in queries[:3]]
    out["cli_similar_seconds"] = float(np.median(walls))
    out["cli_outliers_seconds"] = cli("outliers", catalogue, "--json")[0]
    with tempfile.TemporaryDirectory() as scratch:
        out["cli_outliers_outputs_seconds"] = cli("outliers", catalogue, "-q", "-o", Path(scratch) / "tiles.gpkg",
                                                  "--report", Path(scratch) / "outliers.html")[0]
    print(f"end to end: lidar-sig similar {out['cli_similar_seconds']:.2f} s (median of 3), lidar-sig outliers "
          f"--json {out['cli_outliers_seconds']:.2f} s, with -o tiles.gpkg --report {out['cli_outliers_outputs_seconds']:.2f} s")

    # the shortlist against the full metrics of every tile
    from lidar_sig.survey_catalog._distances import combine, screening

    same, worst = 0, []
    checked = queries[:args.check]
    for q in checked:
        short = cat.similar(q, top=10)
        full = cat.similar(q, top=10, shortlist=len(cat))
        same += short.names() == full.names()
        values = screening(cat.features.row(cat.index(q)), cat.features)
        order = list(np.argsort(combine({k: v[0] for k, v in values.items()}, cat.spread, tuple(values)),
                                kind="stable"))
        worst.append(max(order.index(cat.index(name)) for name in full.names()) + 1)
    out["shortlist_same_top10"] = f"{same} of {len(checked)}"
    out["full_top10_worst_screening_position"] = worst
    print(f"shortlist check: the top 10 from the shortlist are those of the full metrics on all {len(cat):,} tiles "
          f"for {same} of {len(checked)} queries; the full top 10's last tile was at most at position {max(worst)} "
          f"(median {np.median(worst):g}) by screening distance, the shortlist holding {short.shortlist['size']}")
    out["load_after"] = os.getloadavg()[0]
    print(f"load average (1 min) before {out['load_before']:.2f}, after {out['load_after']:.2f}")
    if args.json:
        Path(args.json).write_text(json.dumps(out, indent=1))
    if tmp is not None:
        tmp.cleanup()


if __name__ == "__main__":
    main()
