"""Does compare measure the land, not the survey? The ordering benchmark (issue 8).

    python benchmarks/ordering.py [--data ../shared/data] [--json FILE] [METHOD OPTIONS]

METHOD OPTIONS are those of `lidar-sig compare` (--descriptor, --strategy, --k, --radii,
--units, --weights, --max-neighbors, --classes, --render); none gives the defaults. E.g. the
paper's setting: --units normalized --radii 0.009,0.010,0.011 --weights none --render points.

For every reference tile T, each metric between T and: T itself, T rotated 30 and 90 degrees
about z (in memory, around its centre), a seeded uniform random 80% and 60% of T's points, an
adjacent tile of the same survey, and a tile of another city. Expected order of difference:

    self < rotations < 80% < 60% < adjacent < other city

An inversion is a pair of cases in the wrong order for a metric (a rotation and the other
rotation are not ordered; ties are not inversions). The script prints each metric per case and
the inversions per metric, and, for the claim that matters most, the cases where the 80% sample
is not below the adjacent tile or the adjacent tile not below the other city.

How the tiles are chosen (rules fixed before measuring, not by the metrics under test):
- adjacent: the neighbouring tile of the same survey most alike in class composition (smallest
  L1 of ASPRS class shares): the same kind of ground next door, the hardest case for the 80%
  sample to stay below;
- other city: the tile of another survey most alike in class composition (the hardest case for
  the adjacent tile to stay below). The ISPRS samples' other city is Vaihingen/Enz (FSite8), the
  other town of the same survey.
- IGN 77050_627755 is no reference: it is 40% trees and its most alike neighbour differs in 75%
  of its class composition (a park next to open ground), so "adjacent" would not be the same
  kind of land. Its figures are printed apart, without inversion counts.
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

import lidar_sig as ls
from lidar_sig.cli.options import make_pipeline

KEYS = ("bhattacharyya", "ssim", "emd_info", "emd_img", "fv", "kl", "l1")
NAMES = ("d_BD-Img", "s_SSIM", "d_EMD-Info", "d_EMD-Img", "delta_FV", "delta_KL", "L1")
CASES = ("self", "rotated 30", "rotated 90", "80%", "60%", "adjacent", "other city")
RANK = dict(zip(CASES, (0, 1, 1, 2, 3, 4, 5)))
IGN = "ign_lidarhd_montpellier/test_data_{}_LA93_IGN69.laz"
AHN3 = "ahn3_delft/ahn3_cropped_{}.laz"
ISPRS = "isprs_filtertest/{}-utm.laz"
# (label, T, adjacent, other city), relative to the data folder; see the module docstring
REFERENCES = [
    ("IGN 77050_627760", IGN.format("77050_627760"), IGN.format("77055_627760"), AHN3.format(2)),
    ("IGN 77055_627755", IGN.format("77055_627755"), IGN.format("77060_627755"), AHN3.format(1)),
    ("IGN 77055_627760", IGN.format("77055_627760"), IGN.format("77060_627760"), AHN3.format(1)),
    ("IGN 77060_627755", IGN.format("77060_627755"), IGN.format("77060_627760"), AHN3.format(1)),
    ("IGN 77060_627760", IGN.format("77060_627760"), IGN.format("77060_627755"), AHN3.format(1)),
    ("AHN3 cropped_2", AHN3.format(2), AHN3.format(1), IGN.format("77055_627755")),
    ("ISPRS samp11", ISPRS.format("samp11"), ISPRS.format("samp12"), ISPRS.format("FSite8_red1")),
]
APART = [("IGN 77050_627755", IGN.format("77050_627755"), IGN.format("77055_627755"), AHN3.format(1))]
METHOD_OPTIONS = ("descriptor", "strategy", "k", "radii", "units", "weights", "max_neighbors", "classes")


def load(path):
    """A cloud with its class codes as labels (code 0 kept: ISPRS sites use it for every point)."""
    las = ls.read(path)
    labels = las.labels if las.labels is not None else np.zeros(len(las), np.int64)
    return ls.PointCloud(las.xyz, labels, path=las.path, crs=las.crs, units=las.units)


def rotated(cloud, degrees):
    a = np.radians(degrees)
    rot = np.array([[np.cos(a), -np.sin(a), 0], [np.sin(a), np.cos(a), 0], [0, 0, 1]])
    centre = (cloud.xyz.min(axis=0) + cloud.xyz.max(axis=0)) / 2
    return ls.PointCloud((cloud.xyz - centre) @ rot.T + centre, cloud.labels, crs=cloud.crs, units=cloud.units)


def thinned(cloud, fraction, seed):
    keep = np.random.default_rng(seed).random(len(cloud)) < fraction
    return ls.PointCloud(cloud.xyz[keep], cloud.labels[keep], crs=cloud.crs, units=cloud.units)


def inversions(values, higher_is_closer=False):
    """Pairs of cases (a, b) expected a < b in difference but measured the other way."""
    out = []
    for a in CASES:
        for b in CASES:
            if RANK[a] < RANK[b] and values[a] is not None and values[b] is not None:
                if (values[a] < values[b]) if higher_is_closer else (values[a] > values[b]):
                    out.append((a, b))
    return out


def measure(reference, data, pipeline, render, signatures):
    """{case: metrics against T} for one reference; ``signatures`` caches whole files' runs."""
    label, t_path, adj_path, other_path = reference

    def of_file(rel):
        if rel not in signatures:
            signatures[rel] = pipeline.run(load(data / rel)).signature
        return signatures[rel]

    t = load(data / t_path)
    base = of_file(t_path)
    seed = sum(map(ord, label))
    sigs = {"self": base, "rotated 30": pipeline.run(rotated(t, 30)).signature,
            "rotated 90": pipeline.run(rotated(t, 90)).signature,
            "80%": pipeline.run(thinned(t, 0.8, seed)).signature,
            "60%": pipeline.run(thinned(t, 0.6, seed + 1)).signature,
            "adjacent": of_file(adj_path), "other city": of_file(other_path)}
    return {case: ls.compare(base, sig, render=render) for case, sig in sigs.items()}


def table(label, values):
    lines = [f"\n**{label}**\n", "| case | " + " | ".join(NAMES) + " |", "|---" * (len(NAMES) + 1) + "|"]
    for case in CASES:
        lines.append(f"| {case} | " + " | ".join("n/a" if values[case][k] is None else f"{values[case][k]:.4f}"
                                                for k in KEYS) + " |")
    return "\n".join(lines)


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--data", type=Path, default=Path(__file__).resolve().parents[2] / "shared" / "data")
    parser.add_argument("--json", type=Path, help="Also write every figure to this JSON file.")
    parser.add_argument("--render", choices=ls.signature.RENDERINGS, default="smooth")
    for name in METHOD_OPTIONS:
        parser.add_argument("--" + name.replace("_", "-"), dest=name, default=None,
                            type=int if name == "max_neighbors" else str)
    args = parser.parse_args()
    pipeline = make_pipeline(**{n: getattr(args, n) for n in METHOD_OPTIONS}, quiet=True)
    setting = (f"{pipeline.descriptor.name} {pipeline.strategy.name}, {pipeline.scales.describe()}, "
               f"{pipeline.weights} weights, {args.render} rendering")
    print(f"Ordering benchmark: {setting}")
    signatures, results = {}, {}
    totals = {k: 0 for k in KEYS}
    claims = {k: [] for k in KEYS}
    for ref in REFERENCES:
        values = measure(ref, args.data, pipeline, args.render, signatures)
        results[ref[0]] = values
        print(table(ref[0], values))
        for key in KEYS:
            column = {case: values[case][key] for case in CASES}
            inv = inversions(column, higher_is_closer=key == "ssim")
            totals[key] += len(inv)
            claims[key] += [f"{ref[0]}: {a} > {b}" for a, b in inv
                            if (a, b) in (("80%", "adjacent"), ("adjacent", "other city"))]
    print("\nInversions per metric, over", len(REFERENCES), "references:\n")
    print("| " + " | ".join(NAMES) + " |\n" + "|---" * len(NAMES) + "|")
    print("| " + " | ".join(str(totals[k]) for k in KEYS) + " |")
    print("\nWhere 80% is not below adjacent, or adjacent not below the other city:")
    for key, name in zip(KEYS, NAMES):
        print(f"  {name}: {'; '.join(claims[key]) if claims[key] else 'none'}")
    print("\nApart (not a reference, see the module docstring):")
    for ref in APART:
        values = measure(ref, args.data, pipeline, args.render, signatures)
        results[ref[0]] = values
        print(table(ref[0], values))
    if args.json:
        args.json.write_text(json.dumps({"setting": setting, "inversions": totals, "results": results}, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
