"""Two runs of benchmarks/change_power.py set side by side at equal false flags, from their
``--dump`` files (each evaluated cell with its p-value):

    python benchmarks/power_compare.py BEFORE.json AFTER.json

Per pair kind (the resampled pairs; each campaign difference) and density, the edits BEFORE
found at 95% and the unchanged cells it flagged, then the edits AFTER finds at the p-value
threshold that flags no more unchanged cells than BEFORE did (the largest such threshold,
looser or stricter than 95%), and AFTER at 95%. A change of code that only moves a few cells
near their level moves the figures at 95% both ways; the threshold says whether AFTER finds
fewer edits where it is as often wrong (docs/changes.md, "Rerun with the sample").
"""
from __future__ import annotations

import json
import sys

ALPHA = 0.05


def groups(cells):
    """{(kind, density): (edited cells, unchanged cells)} of the compared cells of a dump."""
    out = {}
    for r in cells:
        if not r["compared"]:
            continue
        pair = r["pair"]
        if pair in ("halves", "copy") or pair.startswith("edited"):
            kind = "resampled"
        else:
            kind = pair.removesuffix(" edited")
        edited, null = out.setdefault((kind, r["density"]), ([], []))
        if r["edit"]:
            edited.append(r["p"])
        elif not pair.endswith("edited") and not pair.startswith("edited"):
            null.append(r["p"])
    return out


def threshold(null, most):
    """The largest p-value threshold t with at most ``most`` of the p-values ``null`` below it
    (1.0 when there are no more than ``most``)."""
    ps = sorted(null)
    return 1.0 if len(ps) <= most else ps[most]


def main(before_path, after_path):
    before, after = (groups(json.load(open(p))) for p in (before_path, after_path))
    print("| pairs | points/m² | before: edits found | before: unchanged cells flagged | after, as often wrong: "
          "edits found | after: its threshold | after at 95%: edits | after at 95%: unchanged flagged |")
    print("|---|---|---|---|---|---|---|---|")
    fewer = 0
    for key in sorted(before, key=lambda k: (k[0] != "resampled", k)):
        if key not in after:
            continue
        (e0, n0), (e1, n1) = before[key], after[key]
        if not e0:
            continue
        found0 = sum(p < ALPHA for p in e0)
        flagged0 = sum(p < ALPHA for p in n0)
        t = threshold(n1, flagged0)
        found1 = sum(p < t for p in e1)
        fewer += found1 < found0
        print(f"| {key[0]} | {key[1]:g} | {found0} / {len(e0)} | {flagged0} / {len(n0)} | {found1} / {len(e1)} | "
              f"p < {t:.3g} | {sum(p < ALPHA for p in e1)} / {len(e1)} | {sum(p < ALPHA for p in n1)} / {len(n1)} |")
    print(f"\nrows where after finds fewer edits as often wrong: {fewer}")


if __name__ == "__main__":
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    main(*sys.argv[1:])
