"""The change map's power beside M3C2 (issue 33): known edits of real survey tiles found, and
unchanged land flagged, per point density, by the change map and by M3C2 in the same run.

Surveys: the six IGN LiDAR HD tiles of Montpellier joined (../shared/data/ign_lidarhd_montpellier)
and the two AHN3 crops of Delft joined (../shared/data/ahn3_delft). For each survey:

- **edited pairs**: the block against an edited copy (benchmarks/power_edits.py: a building
  removed, a building added, trees cut, ground works, new vegetation, each in its own 25 m
  cell; each pair in other cells);
- **unchanged pairs**: halves (epoch A takes a point when its draw u < p, epoch B when
  u >= 1 - p: disjoint while p <= 0.5), and a resampled copy (an independent draw).

Every epoch is thinned to each density (0.1, 0.25, 0.5, 1, 2, 5, 10 points/m²) by a uniform random draw;
epoch B of the edited pairs and of the copy gets 3 cm of Gaussian noise on x, y, z and is moved
by (0.3, -0.2, 0.05) m, as another survey would differ. The change map runs with its defaults
(cell and fewest points chosen from the densities, 95% confidence) on the pairs as they are; a
cell is flagged when it is significant. M3C2 (py4dgeo, ``pip install lidar-sig[bench]``) runs on
the same pairs registered (the move taken back, its best case), each in a process of its own on
one thread (:func:`m3c2_flags`): core points are epoch A's points (at most one per m²), normals and
cylinders of radius max(1 m, sqrt(10 / (pi d))) so that each holds about ten points,
cylinders 15 m long each way, registration error 0; a cell is flagged
when at least :data:`M3C2_SHARE` of its core points (and :data:`M3C2_MIN_CORE` of them or more)
changed significantly (|distance| above M3C2's level of detection; no distance, no change).

Printed: per density and tool (the change map; *score alone*, the score's own level at 95%, the
paper's metrics without delta_H; M3C2), the edited cells flagged per kind of edit, all edits,
and the unchanged cells flagged (of the cells each tool evaluates: compared by the change map, holding
core points for M3C2); then the same per survey. With the campaign kinds, one table more
(:func:`print_campaigns`): each campaign difference per density, the change map beside M3C2
with the benchmark's cell rule and beside M3C2 with a rule matched to the kind's unchanged
cells (at most 5% of them flagged); the unchanged strip pairs are :data:`STRIP_DRAWS` draws.
And a last one (:func:`print_equal_flags`): the edits each tool finds at the rule that flags at
most 5%, 10% and 25% of each kind's unchanged cells, the change map's confidence and M3C2's
share each matched to those cells.

    python benchmarks/change_power.py [--quick] [--seed N] [--pairs 4] [--densities 0.1 0.25 0.5 1 2 5 10]
        [--surveys ign ahn3] [--dump cells.json]

About 9 minutes on a shared 2-core machine; ``--quick`` (densities 0.5, 2 and 10, one edited
pair per survey) about 2.
"""
from __future__ import annotations

import argparse
import json
import logging
import multiprocessing
import os
import sys
import time
import warnings
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))
DATA = ROOT.parent / "shared" / "data"
SURVEYS = {"ign": ("IGN", DATA / "ign_lidarhd_montpellier", 5),
           "ahn3": ("AHN3", DATA / "ahn3_delft", 1)}
DENSITIES = (0.1, 0.25, 0.5, 1.0, 2.0, 5.0, 10.0)
NOISE, SHIFT = 0.03, (0.3, -0.2, 0.05)
#: M3C2: a cell is flagged when this share of its core points changed significantly, and it
#: holds this many core points or more. 15%: the smallest multiple of 5% that flags at most 5%
#: of IGN's unchanged cells at every density; AHN3's confirm it from 0.25 points/m² up
#: (docs/changes.md, "Power beside M3C2").
M3C2_SHARE, M3C2_MIN_CORE = 0.15, 10
M3C2_LENGTH = 15.0
NULLS = ("halves", "copy")
#: Unchanged strip pairs per density and survey, each its own draw of both strips: a strip
#: overlap holds only 18 (IGN) or 31 (AHN3) compared cells, so one draw says little of the
#: share of unchanged cells flagged (one draw gave 4 of 49 at 0.25 points/m², six 13 of 291).
STRIP_DRAWS = 6
#: Shares of unchanged cells at which the tools are set side by side (:func:`print_equal_flags`).
FLAG_LIMITS = (0.05, 0.10, 0.25)
#: The change map's confidences tried there, highest first: the steps of 5% that
#: ``lidar-sig changes --confidence`` accepts, and 97.5% and 99% above them.
CONFIDENCES = (0.99, 0.975) + tuple(k / 20 for k in range(19, 9, -1))


def thinned(block, xyz, labels, keep, rng=None, name="epoch", moved=False):
    """The points ``keep`` of ``xyz``, ``labels`` as a PointCloud in ``block``'s CRS; ``moved``:
    with :data:`NOISE` of Gaussian noise (drawn from ``rng``) and moved by :data:`SHIFT`."""
    from lidar_sig.method.cloud import PointCloud

    xyz = xyz[keep]
    if moved:
        xyz = xyz + rng.normal(0.0, NOISE, xyz.shape) + np.asarray(SHIFT)
    return PointCloud(np.round(xyz, 3), labels[keep], path=name, crs=block.crs, units=block.units)


def m3c2_shares(a, b, density):
    """(core points (N, 2) x, y; whether each changed significantly) of M3C2 from A to B."""
    import py4dgeo

    py4dgeo.set_py4dgeo_logfile(os.devnull)  # it writes py4dgeo.log in the working folder otherwise
    logging.getLogger("py4dgeo").setLevel(logging.WARNING)  # its KD-tree notes, twice a pair
    py4dgeo.set_num_threads(1)  # see m3c2_flags
    rng = np.random.default_rng(0)
    core = a[rng.random(len(a)) < min(1.0, 1.0 / density)]
    radius = max(1.0, float(np.sqrt(10.0 / (np.pi * density))))
    epochs = (py4dgeo.Epoch(a), py4dgeo.Epoch(b))
    m3c2 = py4dgeo.M3C2(epochs=epochs, corepoints=core, cyl_radius=radius, normal_radii=(radius,),
                        max_distance=M3C2_LENGTH, registration_error=0.0)
    distances, uncertainties = m3c2.run()
    return core[:, :2], np.abs(distances) > uncertainties["lodetection"]  # NaN: no distance, no change


def m3c2_flags(pool, a, b, grid, density):
    """(core points, share of them changed significantly) per flat cell of ``grid``, M3C2 run in
    a process of its own for each pair, on one thread: py4dgeo 1.2 gave other distances for the
    same pair once the objects of an earlier M3C2 run in the same process had been freed (up to
    340 of 27,000 core points changed their verdict; none while they were kept), and with more
    threads; so the table is the same from one run to the next."""
    core, changed = pool.submit(m3c2_shares, a, b, density).result()
    cells = grid.cell_of(core)
    inside = cells >= 0
    n = np.bincount(cells[inside], minlength=grid.n_cells)
    k = np.bincount(cells[inside], weights=changed[inside], minlength=grid.n_cells)
    return n, np.where(n > 0, k / np.maximum(n, 1), 0.0)


def run_pair(pool, epoch_a, b, moved, pipeline, density, class_map, seed):
    """Both tools on one pair: the change map (on B as it is, with ``class_map`` where the
    epochs' class schemes differ, its resamples drawn from ``seed``), and M3C2's core points and
    share of them changed per cell (on B registered: the move taken back)."""
    import lidar_sig as ls

    cm = ls.changes(epoch_a, b, pipeline=pipeline, class_map=class_map, seed=seed)
    registered = b.xyz - np.asarray(SHIFT) if moved else b.xyz
    n_core, share = m3c2_flags(pool, epoch_a.cloud.xyz, registered, cm.grid, density)
    return cm, n_core, share


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--quick", action="store_true", help="densities 0.5, 2, 10, one edited pair per survey")
    parser.add_argument("--pairs", type=int, default=4, help="edited pairs per survey (each in other cells)")
    parser.add_argument("--densities", type=float, nargs="+", default=list(DENSITIES))
    parser.add_argument("--surveys", nargs="+", choices=sorted(SURVEYS), default=["ign", "ahn3"])
    parser.add_argument("--dump", help="write every evaluated cell as JSON (for other thresholds)")
    parser.add_argument("--kinds", nargs="+", choices=("resampled", "campaigns"), default=["resampled", "campaigns"],
                        help="resampled: halves, copy and edited copies of one flight; campaigns: strip pairs and "
                             "modelled campaign differences, each null and edited (benchmarks/campaigns.py)")
    parser.add_argument("--seed", type=int, default=None,
                        help="the change map's resamples' seed (default: the map's own): how far the draws "
                             "alone move a row (docs/changes.md, \"Rerun with the sample\")")
    args = parser.parse_args()
    if args.dump and not Path(args.dump).resolve().parent.is_dir():  # said now, not after the run
        parser.error(f"--dump {args.dump}: its folder does not exist; create it or give another path")
    if args.quick:
        args.densities, args.pairs = [0.5, 2.0, 10.0], 1
    import lidar_sig as ls
    from power_edits import EDITS, edit_block

    from lidar_sig.change_map import density as density_of
    from lidar_sig.change_map import SEED, compute_epoch, read_epoch
    from lidar_sig.base.errors import LidarSigWarning

    warnings.simplefilter("ignore", LidarSigWarning)
    pipeline = ls.Pipeline(progress=False)
    seed = SEED if args.seed is None else args.seed
    cells = []  # one record per evaluated cell
    start = time.perf_counter()
    pool = ProcessPoolExecutor(1, mp_context=multiprocessing.get_context("spawn"), max_tasks_per_child=1)
    for key in args.surveys:
        title, folder, vegetation = SURVEYS[key]
        block = read_epoch(folder)
        kept = pipeline.kept(block)
        xyz, labels = (block.xyz, block.labels) if kept is None else (block.xyz[kept], block.labels[kept])
        full = density_of(xyz[:, :2])
        edited = [edit_block(xyz, labels, vegetation=vegetation, rank=r) for r in range(args.pairs)]
        campaign = (Campaign(key, folder, block, kept, xyz, labels, vegetation, edited[0] if edited else None)
                    if "campaigns" in args.kinds else None)
        print(f"{title}: {len(xyz):,} points, {full:.1f} points/m²; edited cells: " + "; ".join(
            ", ".join(f"{e} {c}" for e, c in edits.items()) for _, _, edits in edited), file=sys.stderr)
        for d in args.densities:
            p = d / full
            if p > 1:
                print(f"{title}: {d:g} points/m² is more than the survey holds, left out", file=sys.stderr)
                continue
            rng = np.random.default_rng([int(d * 100), 1])
            u = rng.random(len(xyz))
            a = thinned(block, xyz, labels, u < p, name="A")
            epoch_a = compute_epoch(a, pipeline)
            pairs = []
            if "resampled" in args.kinds:
                pairs += [("halves", {}, False, thinned(block, xyz, labels, u >= 1 - p, name="B (other half)")),
                          ("copy", {}, True, thinned(block, xyz, labels, rng.random(len(xyz)) < p, rng, "B (copy)",
                                                     True))]
                for r, (e_xyz, e_labels, edits) in enumerate(edited):
                    pairs.append((f"edited {r + 1}", edits, True, thinned(block, e_xyz, e_labels,
                                                                          rng.random(len(e_xyz)) < p, rng, "B", True)))
            if "campaigns" in args.kinds:
                pairs += campaign_pairs(campaign, block, d, p, epoch_a, pipeline, np.random.default_rng([int(d * 100), 2]))
            for kind, edits, moved, b, *given in pairs:
                epoch, class_map = given if given else (epoch_a, None)
                if epoch is None:
                    continue
                t0 = time.perf_counter()
                cm, n_core, share = run_pair(pool, epoch, b, moved, pipeline, d, class_map, seed)
                edit_of = {}
                for name, (i, j) in edits.items():
                    centre = np.array([[(i + 0.5) * 25.0, (j + 0.5) * 25.0]])
                    edit_of[int(cm.grid.cell_of(centre)[0])] = name
                t = cm.table
                for c in range(cm.grid.n_cells):
                    if not (t["valid"][c] or n_core[c] >= M3C2_MIN_CORE or c in edit_of):
                        continue
                    rec = {"survey": key, "density": d, "pair": kind, "edit": edit_of.get(c), "cell": c,
                           "row": int(t["row"][c]), "col": int(t["col"][c]),
                           "compared": bool(t["valid"][c]), "points": [int(t["points_a"][c]), int(t["points_b"][c])],
                           "flagged": bool(t["significant"][c]), "alone": bool(cm.levels[cm.score].significant[c]),
                           "p": float(t["p"][c]) if t["valid"][c] else None,  # NaN is not JSON
                           "core": int(n_core[c]), "m3c2_share": float(share[c])}
                    if t["valid"][c]:
                        rec["levels"] = {k: [float(t[k][c]), float(lv.mu0[c]), float(lv.sigma[c])]
                                         for k, lv in cm.levels.items()}
                    cells.append(rec)
                print(f"{title} {d:g}/m² {kind}: {int(t['valid'].sum())} cells of {cm.cell:g} m (min "
                      f"{cm.min_points}), {cm.n_significant} significant; {time.perf_counter() - t0:.1f} s",
                      file=sys.stderr)
    pool.shutdown()
    if args.dump:  # whole or not at all: a run interrupted while writing leaves no half file
        part = Path(args.dump).with_name(Path(args.dump).name + ".part")
        part.write_text(json.dumps(cells))
        os.replace(part, args.dump)
    if "resampled" in args.kinds:
        print_tables([r for r in cells if r["pair"] in NULLS or r["pair"].startswith("edited")], args.densities,
                     EDITS, args.surveys)
    if "campaigns" in args.kinds:
        from campaigns import KINDS

        for kind in KINDS:
            print_tables([r for r in cells if r["pair"] in (kind, f"{kind} edited")], args.densities, EDITS,
                         args.surveys, nulls=(kind,), title=f"{kind}: ")
        print_campaigns(cells, args.densities, KINDS)
        print_equal_flags(cells, args.densities, KINDS)
    print(f"\n{time.perf_counter() - start:.0f} s in all", file=sys.stderr)


class Campaign:
    """A survey's campaign differences, made once (benchmarks/campaigns.py): its two most
    overlapping strips (the second also edited inside the cells both cover fully), the block
    misaligned strip by strip (and its edited copy), and the edited block of the resampled pairs."""

    def __init__(self, key, folder, block, kept, xyz, labels, vegetation, edited):
        from campaigns import block_sources, edits_in, misaligned, strip_pair
        from power_edits import edit_block

        source = block_sources(folder, len(block.xyz))
        source = source if kept is None else source[kept]
        self.key, self.vegetation, self.xyz, self.labels, self.edited = key, vegetation, xyz, labels, edited
        self.strips, shared = strip_pair(xyz, source)
        one, two = (source == k for k in self.strips)
        self.strip_a, self.strip_b = (xyz[one], labels[one]), (xyz[two], labels[two])
        self.strip_b_edited = edits_in(xyz[two], labels[two], shared[two], vegetation=vegetation)
        self.misaligned = misaligned(xyz, source, np.random.default_rng(38))
        self.misaligned_edited = edit_block(self.misaligned, labels, vegetation=vegetation)


def campaign_pairs(c, block, d, p, epoch_a, pipeline, rng):
    """[(kind, edits, moved, B, epoch A, class map)] of the campaign kinds at density ``d``
    (``p`` of the block's points): each null and edited; the strips thinned to ``d`` each,
    the others against the block's ``epoch_a``."""
    from campaigns import DENSITY_RATIO, SCHEMES, leaf_off, one_edit, other_scheme

    from lidar_sig.change_map import compute_epoch
    from lidar_sig.change_map import density as density_of

    def cloud(x, l, name, share=1.0):
        return thinned(block, x, l, rng.random(len(x)) < share, name=name)

    pairs = []
    (xa, la), (xb, lb) = c.strip_a, c.strip_b
    pa, pb = d / density_of(xa[:, :2]), d / density_of(xb[:, :2])
    if max(pa, pb) <= 1:
        strip_a = compute_epoch(cloud(xa, la, f"strip {c.strips[0]}", pa), pipeline)
        pairs.append(("strips", {}, False, cloud(xb, lb, f"strip {c.strips[1]}", pb), strip_a, None))
        for kind in c.strip_b_edited[2]:  # one edit per pair: the overlap is small (benchmarks/campaigns.py)
            ex, el, edits = one_edit(xb, lb, c.strip_b_edited, kind)
            pairs.append(("strips edited", edits, False, cloud(ex, el, f"strip {c.strips[1]}, {kind}", pb), strip_a,
                          None))
    e_xyz, e_labels, edits = c.edited
    plain, changed = (c.xyz, c.labels, {}), (e_xyz, e_labels, edits)
    for kind, (x, l, e) in (("leaf-off", plain), ("leaf-off edited", changed)):
        keep = rng.random(len(x)) < p
        lx, ll = leaf_off(x[keep], l[keep], c.vegetation, rng)
        pairs.append((kind, e, False, cloud(lx, ll, kind), epoch_a, None))
    mx, ml, m_edits = c.misaligned_edited
    for kind, (x, l, e) in (("misaligned", (c.misaligned, c.labels, {})), ("misaligned edited", (mx, ml, m_edits))):
        pairs.append((kind, e, False, cloud(x, l, kind, p), epoch_a, None))
    if p * DENSITY_RATIO <= 1:
        for kind, (x, l, e) in (("density x3", plain), ("density x3 edited", changed)):
            pairs.append((kind, e, False, cloud(x, l, kind, p * DENSITY_RATIO), epoch_a, None))
    _, class_map = SCHEMES[c.key]
    for kind, (x, l, e) in (("class scheme", plain), ("class scheme edited", changed)):
        pairs.append((kind, e, False, cloud(x, other_scheme(l, c.key), kind, p), epoch_a, class_map))
    if max(pa, pb) <= 1:  # more unchanged strip pairs, each its own draw of both strips (last: the
        # other pairs keep the draws of the benchmark's earlier runs)
        for draw in range(2, STRIP_DRAWS + 1):
            other = compute_epoch(cloud(xa, la, f"strip {c.strips[0]} (draw {draw})", pa), pipeline)
            pairs.append(("strips", {}, False, cloud(xb, lb, f"strip {c.strips[1]} (draw {draw})", pb), other, None))
    return pairs


def m3c2_flag(rec, share=M3C2_SHARE):
    return rec["core"] >= M3C2_MIN_CORE and rec["m3c2_share"] >= share


def loosest_rule(rules, flag, null, limit):
    """The first of ``rules`` (loosest first) under which ``flag(record, rule)`` flags at most
    ``limit`` of the records ``null``; None if none does, or there is no record."""
    return next((rule for rule in rules if null and sum(flag(r, rule) for r in null) <= limit * len(null)), None)


def matched_share(null, limit=0.05):
    """The smallest multiple of 5% of core points changed that, as M3C2's cell rule, flags at most
    ``limit`` of the unchanged cells ``null`` that hold :data:`M3C2_MIN_CORE` core points; None if
    even 100% flags more, or there is no such cell."""
    cored = [r for r in null if r["core"] >= M3C2_MIN_CORE]
    # k / 20, not k * 0.05: 19 * 0.05 is above 0.95
    return loosest_rule([k / 20 for k in range(1, 21)], m3c2_flag, cored, limit)


def kind_cells(cells, densities, kinds):
    """(kind, density, edited cells, cells of the unchanged pairs) of every campaign ``kinds``
    and ``densities`` with edited cells among the records ``cells``."""
    for kind in kinds:
        for d in densities:
            edited = [r for r in cells if r["pair"] == f"{kind} edited" and r["density"] == d and r["edit"]]
            if edited:
                yield kind, d, edited, [r for r in cells if r["pair"] == kind and r["density"] == d]


def print_campaigns(cells, densities, kinds):
    """The table of docs/changes.md, "Between campaigns": per campaign difference and density,
    edits found and unchanged cells flagged by the change map, by M3C2 with the benchmark's
    cell rule, and by M3C2 with the rule matched to the pairs (:func:`matched_share`: the
    smallest share that flags at most 5% of this kind's unchanged cells at this density,
    chosen on the very cells it is judged on, its best case), both surveys."""
    print("\n| campaign difference | points/m² | change map: edits found | change map: unchanged cells flagged "
          f"| M3C2 ({M3C2_SHARE:.0%} rule): edits found | M3C2 ({M3C2_SHARE:.0%} rule): unchanged cells flagged "
          "| M3C2, matched rule | M3C2, matched rule: edits found | M3C2, matched rule: unchanged cells flagged |")
    print("|---|---|---|---|---|---|---|---|---|")

    def count(flag, of):
        return f"{sum(map(flag, of))} / {len(of)}"

    def share(flag, of):
        return f"{sum(map(flag, of)) / max(len(of), 1):.1%} ({count(flag, of)})"

    for kind, d, edited, null in kind_cells(cells, densities, kinds):
        compared = [r for r in null if r["compared"]]
        cored = [r for r in null if r["core"] >= M3C2_MIN_CORE]
        matched = matched_share(cored)
        row = [kind, f"{d:g}", count(lambda r: r["compared"] and r["flagged"], edited),
               share(lambda r: r["flagged"], compared), count(m3c2_flag, edited), share(m3c2_flag, cored)]
        if matched is None:
            row += ["none flags 5% or fewer" if cored else "no unchanged cells", "-", "-"]
        else:
            flag = lambda r: m3c2_flag(r, matched)  # noqa: E731
            row += [f"{matched:.0%}", count(flag, edited), share(flag, cored)]
        print("| " + " | ".join(row) + " |")


def map_flag(rec, confidence):
    """Whether the change map flags the cell of ``rec`` at ``confidence``: compared and its
    p-value (over its two tests) below 1 - confidence, exactly its significance at that
    confidence (docs/changes.md, "Significance")."""
    return rec["compared"] and rec["p"] < 1.0 - confidence


def matched_confidence(null, limit=0.05):
    """The lowest confidence of :data:`CONFIDENCES` at which the change map flags at most
    ``limit`` of the compared unchanged cells ``null``; None if even the highest flags more, or
    there is no such cell."""
    return loosest_rule(sorted(CONFIDENCES), map_flag, [r for r in null if r["compared"]], limit)


def print_equal_flags(cells, densities, kinds, limits=FLAG_LIMITS):
    """The table of docs/changes.md, "At equal false flags": per campaign difference and
    density, the edits each tool finds at the rule that flags at most each of ``limits`` of
    that kind's unchanged cells (the change map's confidence, :func:`matched_confidence`;
    M3C2's share of core points, :func:`matched_share`), both chosen on the very cells they are
    judged on. Set beside each other, the tools are compared where they are equally wrong."""
    head = " | ".join(f"at most {limit:.0%} flagged: change map | M3C2" for limit in limits)
    print(f"\n| campaign difference | points/m² | {head} |")
    print("|---|---|" + "---|---|" * len(limits))
    for kind, d, edited, null in kind_cells(cells, densities, kinds):
        row = [kind, f"{d:g}"]
        for limit in limits:
            confidence = matched_confidence(null, limit)
            share = matched_share(null, limit)
            row.append("-" if confidence is None else
                       f"{sum(map_flag(r, confidence) for r in edited)} / {len(edited)} at {confidence:.1%}")
            row.append("-" if share is None else
                       f"{sum(m3c2_flag(r, share) for r in edited)} / {len(edited)} at {share:.0%}")
        print("| " + " | ".join(row) + " |")


def print_tables(cells, densities, edits, surveys, nulls=NULLS, title=""):
    """The table of docs/changes.md: per density and tool, edits found per kind, all edits,
    unchanged cells flagged (of the pairs ``nulls``); then per survey."""
    tools = (("change map", lambda r: r["compared"] and r["flagged"], lambda r: r["compared"]),
             ("score alone", lambda r: r["compared"] and r["alone"], lambda r: r["compared"]),
             ("M3C2", m3c2_flag, lambda r: r["core"] >= M3C2_MIN_CORE))

    def table(subset, label):
        print(f"\n{label}")
        print("| points/m² | tool | " + " | ".join(edits) + " | all edits | unchanged cells flagged |")
        print("|---|---|" + "---|" * (len(edits) + 2))
        for d in densities:
            here = [r for r in subset if r["density"] == d]
            if not here:
                continue
            for name, flag, evaluated in tools:
                row = []
                for e in edits:
                    of = [r for r in here if r["edit"] == e]
                    row.append(f"{sum(map(flag, of))} / {len(of)}")
                of = [r for r in here if r["edit"]]
                row.append(f"{sum(map(flag, of)) / max(len(of), 1):.0%} ({sum(map(flag, of))} / {len(of)})")
                null = [r for r in here if r["pair"] in nulls and evaluated(r)]
                row.append(f"{sum(map(flag, null)) / max(len(null), 1):.1%} ({sum(map(flag, null))} / {len(null)})")
                print(f"| {d:g} | {name} | " + " | ".join(row) + " |")

    table(cells, f"{title}Both surveys")
    for s in surveys:
        table([r for r in cells if r["survey"] == s], f"{title}{SURVEYS[s][0]}")


if __name__ == "__main__":
    main()
