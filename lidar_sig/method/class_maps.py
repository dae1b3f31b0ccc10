"""Two clouds' classification schemes: whether their class codes overlap (the warning `compare`
and `changes` give when they barely do), and a class map that merges codes of either cloud into
one class, so that two schemes can be made comparable on purpose (``--class-map``).

Surveys classify differently: AHN3 keeps vegetation in class 1 (unclassified), IGN LiDAR HD in
3, 4 and 5. The semantic metrics (delta_KL, L1) of two such clouds measure the schemes as much
as the land; a class map ``1,3,4,5=vegetation-or-other`` gives both one class for those codes.
"""
from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from .classes import MAX_CODE, ClassTable
from ..base.errors import LidarSigError, a_kind

#: Share of a cloud's points in classes the other cloud does not use above which the clouds are
#: said to be classified differently.
CLASS_OVERLAP_WARNING = 0.10
#: How a class map is written on the command line (given in every error about one).
EXAMPLE = "1,3,4,5=vegetation-or-other"


def class_scheme_warnings(totals_a, totals_b, class_names, names, *,
                          consequence="delta_KL and L1 measure the classification schemes as much as the land"):
    """Warnings (texts) for each cloud whose points are largely (more than
    :data:`CLASS_OVERLAP_WARNING`) in classes the other does not use.

    ``totals_a``, ``totals_b``: (C,) points per class of one class table, whose
    ``class_names`` name them; ``names``: the two clouds' names; ``consequence`` what the
    caller's figures then measure."""
    pa, pb = (np.asarray(t, np.float64) for t in (totals_a, totals_b))
    out = []
    for name, p, q in ((names[0], pa, pb), (names[1], pb, pa)):
        alone = (p > 0) & (q == 0)
        share = p[alone].sum() / max(p.sum(), 1.0)
        if share > CLASS_OVERLAP_WARNING:
            classes = ", ".join(n for n, on in zip(class_names, alone) if on)
            out.append(f"{share:.0%} of the points of {name} are in classes the other cloud does not use "
                       f"({classes}): the clouds are classified differently, so {consequence}")
    return out


def parse_class_map(value):
    """{class name: sorted codes} from a class map given as text (``"1,3,4,5=vegetation"``,
    several joined by ``;``), a dict {name: codes}, a ``.toml`` / ``.json`` file of such a
    dict, or a list of any of these; a LidarSigError naming the value and the fix otherwise.
    None or empty: no map."""
    if value is None:
        return {}
    items = list(value) if isinstance(value, (list, tuple)) else [value]
    merged = {}
    for item in items:
        if isinstance(item, dict):
            part = _checked(dict(item), repr(item))
        elif isinstance(item, (str, Path)) and str(item).lower().endswith((".toml", ".json")):
            part = _checked(_read_file(Path(item)), str(item))
        elif isinstance(item, str):
            part = _checked(_parse_text(item), item)
        else:
            raise LidarSigError(f"a class map is text like {EXAMPLE!r}, a dict {{name: [codes]}} or a .toml/.json "
                                f"file, got {a_kind(item)}")
        for name in part:
            if name in merged:
                raise LidarSigError(f"class map: {name!r} is given twice; list all its codes once")
        merged.update(part)
    return _checked(merged, "; ".join(map(str, items))) if merged else {}


def _parse_text(text):
    merged = {}
    for part in (p.strip() for p in text.split(";")):
        if not part:
            continue
        codes, sep, name = part.partition("=")
        if not sep or not name.strip():
            raise LidarSigError(f"class map {part!r}: write the codes, '=' and the merged class's name, as in "
                                f"{EXAMPLE}")
        if not re.fullmatch(r"\s*\d+(\s*,\s*\d+)*\s*", codes):
            raise LidarSigError(f"class map {part!r}: the codes before '=' must be whole numbers separated by "
                                f"commas, as in {EXAMPLE}")
        name = name.strip()
        if name in merged:
            raise LidarSigError(f"class map {part!r}: {name!r} is given twice; list all its codes once")
        merged[name] = [int(c) for c in codes.split(",")]
    if not merged:
        raise LidarSigError(f"class map {text!r}: give at least one merged class, as in {EXAMPLE}")
    return merged


def _read_file(path):
    if not path.is_file():
        raise LidarSigError("class map file not found; check the path", path=path)
    try:
        text = path.read_text(encoding="utf-8")
        if path.suffix.lower() == ".toml":
            import tomllib

            return tomllib.loads(text)
        import json

        return json.loads(text)
    except (ValueError, UnicodeDecodeError) as exc:
        raise LidarSigError(f"cannot parse the class map ({str(exc).splitlines()[0][:120]}); write "
                            "{\"vegetation-or-other\": [1, 3, 4, 5]} (JSON) or vegetation-or-other = [1, 3, 4, 5] "
                            "(TOML)", path=path) from None


def _checked(mapping, shown):
    if not isinstance(mapping, dict) or not mapping:
        raise LidarSigError(f"class map {shown}: give at least one merged class, as in {EXAMPLE}")
    out, seen = {}, {}
    for name, codes in mapping.items():
        codes = [codes] if isinstance(codes, int) and not isinstance(codes, bool) else codes
        whole = isinstance(codes, (list, tuple)) and codes and all(
            isinstance(c, (int, np.integer)) and not isinstance(c, bool) and 0 <= c <= MAX_CODE for c in codes)
        if not isinstance(name, str) or not name.strip() or not whole:
            raise LidarSigError(f"class map {shown}: each merged class needs a name and a list of codes, whole "
                                f"numbers from 0 to {MAX_CODE:,}, as in {EXAMPLE}")
        for c in codes:
            if int(c) in seen and seen[int(c)] != name:
                raise LidarSigError(f"class map {shown}: code {int(c)} is merged into both {seen[int(c)]!r} and "
                                    f"{name!r}; give each code to one class")
            seen[int(c)] = name
        out[name.strip()] = sorted({int(c) for c in codes})
    return out


def merge_classes(table, class_map):
    """The class table ``table`` with the codes of each merged class of ``class_map`` (as
    :func:`parse_class_map` takes it) taken from their classes into one class of its own,
    placed where its first class was and coloured by the mean colour of the classes it merges;
    classes left without codes are dropped, codes not mapped keep their classes."""
    merged = parse_class_map(class_map)
    if not merged:
        return table
    owner = {c: name for name, codes in merged.items() for c in codes}
    colours = {k: np.asarray(table.class_colors[k] * 255.0) for k in range(len(table))}
    names, codes, rgb = [], [], []
    placed = set()
    for k, (name, cs) in enumerate(zip(table.names, table.codes)):
        for target in sorted({owner[c] for c in cs if c in owner}, key=list(merged).index):
            if target not in placed:
                placed.add(target)
                names.append(target)
                codes.append(tuple(merged[target]))
                rgb.append(_mean_colour(table, merged[target], colours))
        kept = tuple(c for c in cs if c not in owner)
        if kept:
            names.append(name)
            codes.append(kept)
            rgb.append(tuple(table.colors[k]))
    for target in merged:  # codes the table does not name (its "other")
        if target not in placed:
            names.append(target)
            codes.append(tuple(merged[target]))
            rgb.append(_mean_colour(table, merged[target], colours))
    try:
        return ClassTable(f"{table.name}, merged", tuple(names), tuple(codes), tuple(rgb), noise=table.noise)
    except LidarSigError as exc:
        raise LidarSigError(f"class map: {exc}; name the merged class differently") from None


def _mean_colour(table, codes, colours):
    index = table.index(np.asarray(codes))
    return tuple(int(round(v)) for v in np.mean([colours[int(k)] for k in index], axis=0))
