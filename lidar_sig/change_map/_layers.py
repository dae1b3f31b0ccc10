"""The change map as GIS layers (docs/changes.md, Outputs): the cells as polygons with their
coverage, score, level of detection, significance and the classes that changed most (a
GeoPackage layer), the styles QGIS draws the map and the cells with, and the later epoch's
points with their cell's change (extra dimensions of a point cloud)."""
from __future__ import annotations

import numpy as np

from ..metrics import METRIC, METRIC_KEYS
from ._cells import COVERAGE as STATES
from ._cells import COVERAGE_CHANGES
from ..reporting.change_scale import CHANGE_SCALE

#: Each covered cell's coverage, in the legend's order; cells neither epoch covers are left out.
COVERAGE = ("compared", "appeared", "vanished", "too few points")
#: What each coverage means, for the legend.
COVERAGE_MEANS = {"compared": "compared", "appeared": "appeared: only the later epoch has points",
                  "vanished": "vanished: only the earlier epoch has points",  # enough to compare, both
                  "too few points": "too few points to compare"}
#: The classes of the change map's colours and the outline of a significant cell: the one colour
#: scale of change (:data:`lidar_sig.reporting.change_scale.CHANGE_SCALE`), which every face uses.
LEVEL_CLASSES = CHANGE_SCALE.classes
SIGNIFICANT_OUTLINE = CHANGE_SCALE.outline
#: Classes listed per cell as changed most, at most, and the least change listed (points of share).
CLASSES_LISTED = 3
CLASS_CHANGE_MIN = 1.0


def coverage(table):
    """(cells,) text: each cell's coverage state, the name of the table's ``coverage`` code
    (:data:`lidar_sig.change_map._cells.COVERAGE`: compared, appeared, vanished, too few points);
    "" where neither epoch holds a point."""
    names = np.array([STATES.get(code, "") for code in range(max(STATES) + 1)], dtype=object)
    names[0] = ""  # not covered: no layer feature
    return names[table["coverage"].astype(np.int64)]


def class_changes(names, counts_a, counts_b):
    """[(class, change in points of share, B's share minus A's)] of one cell, largest change
    first, at most :data:`CLASSES_LISTED` of at least :data:`CLASS_CHANGE_MIN` points; [] where
    an epoch has no point."""
    if counts_a.sum() == 0 or counts_b.sum() == 0:
        return []
    change = 100.0 * (counts_b / counts_b.sum() - counts_a / counts_a.sum())
    order = np.argsort(-np.abs(change), kind="stable")[:CLASSES_LISTED]
    return [(names[k], float(change[k])) for k in order if abs(change[k]) >= CLASS_CHANGE_MIN]


def drawn_cells(cm):
    """(cells,) bool: the cells the cells layer holds: those compared, appeared or vanished,
    and those with too few points inside either epoch's footprint (:func:`~._cells.footprint`:
    a pond, a dark roof); not the slivers of points that a survey's edge leaves in the cells
    of the grid it half crosses, which are outside both footprints and say nothing."""
    from ._cells import HOLE_M2, covering, footprint

    t = cm.table
    shape = (cm.grid.rows, cm.grid.cols)
    least = covering(cm.min_points)
    most = max(1, int(HOLE_M2 // (cm.cell * cm.cell)))
    inside = np.zeros(len(t), bool)
    for points in (t["points_a"], t["points_b"]):
        inside |= footprint((points >= least).reshape(shape), most).ravel()
    sparse = t["coverage"] == next(code for code, name in STATES.items() if name == "too few points")
    return (t["coverage"] > 0) & (~sparse | inside)


def cell_features(cm):
    """[(ring (5, 2), fields)] of every cell either epoch covers (:func:`drawn_cells`): row, col, coverage
    (:func:`coverage`), points of each epoch, rank (most changed first, compared cells), score, level of detection, z,
    lod_ratio, significant (1/0; NULL where not compared), changed (1/0: significant, or appeared or vanished
    inside the other epoch's footprint; NULL with too few points), p and q, the metrics in which it changed
    significantly, every metric, and the classes that changed most (share of B minus share of A, points)."""
    t = cm.table
    state = coverage(t)
    state[~drawn_cells(cm)] = ""  # slivers at the surveys' edges: no feature
    ranks = np.zeros(len(t), np.int64)
    ranks[cm.ranked()] = np.arange(1, int(t["valid"].sum()) + 1)
    names = cm.class_table.class_names
    features = []
    for i in np.flatnonzero(state != ""):
        rec = t[i]
        x0, y0, x1, y1 = (float(rec[k]) for k in ("x_min", "y_min", "x_max", "y_max"))
        ring = np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1], [x0, y0]])
        compared = bool(rec["valid"])
        changed = class_changes(names, cm.classes_a[i], cm.classes_b[i])
        fields = {"row": int(rec["row"]), "col": int(rec["col"]), "coverage": str(state[i]),
                  "points_a": int(rec["points_a"]), "points_b": int(rec["points_b"]),
                  "rank": int(ranks[i]) if compared else None, "score": _number(rec["score"]),
                  "lod": _number(rec["lod"]), "z": _number(rec["z"]), "lod_ratio": _number(rec["lod_ratio"]),
                  "significant": int(rec["significant"]) if compared else None,
                  "changed": int(rec["changed"]) if compared or rec["coverage"] in COVERAGE_CHANGES else None,
                  "p": _number(rec["p"]), "q": _number(rec["q"]),
                  "significant_metrics": ", ".join(k for k in METRIC_KEYS if k in cm.levels
                                                   and cm.levels[k].significant[i]) if compared else None,
                  **{k: _number(rec[k]) for k in METRIC_KEYS},
                  "top_class": changed[0][0] if changed else None,
                  "top_class_change": changed[0][1] if changed else None,
                  "classes_changed": "; ".join(f"{name} {change:+.1f} pts" for name, change in changed) or None}
        features.append((ring, fields))
    return features


#: SQL types of the cells' fields that may be NULL in every cell.
CELL_TYPES = {"rank": "INTEGER", "significant": "INTEGER", "changed": "INTEGER", "p": "REAL", "q": "REAL",
              "significant_metrics": "TEXT", "top_class": "TEXT",
              "top_class_change": "REAL", "classes_changed": "TEXT", "score": "REAL", "lod": "REAL", "z": "REAL",
              "lod_ratio": "REAL",
              **{k: "REAL" for k in METRIC_KEYS}}


def cells_layer(cm, name="cells"):
    """The cells as a :class:`lidar_sig.io.geopackage.Layer` with its default style, listing the
    rules that draw one of its cells."""
    from ..io.geopackage import Layer

    ranking = METRIC[cm.score].distance_name
    features = cell_features(cm)
    return Layer(name, cm.crs, features, f"change map cells of {cm.cell:g} m: {cm.a.name} -> {cm.b.name}, "
                 f"score {ranking}, {cm.confidence:.0%} level of detection", CELL_TYPES,
                 cells_style([fields for _, fields in features]))


def interval_layer_names(series):
    """The table name of each interval's cells in a series' GeoPackage: ``cells_<A>_to_<B>``
    from the epochs' file names (letters, digits and _ only, as GIS expect of a table), the
    interval's number added where two intervals would take the same name."""
    import re
    from pathlib import Path

    def stem(epoch):
        return re.sub(r"[^0-9A-Za-z]+", "_", Path(epoch.name).stem).strip("_") or "epoch"

    names = [f"cells_{stem(series.epochs[k])}_to_{stem(series.epochs[k + 1])}" for k in range(len(series.maps))]
    return [f"{n}_{k + 1}" if names.count(n) > 1 else n for k, n in enumerate(names)]


#: Decimals QGIS shows of the cells' numbers (their values are kept whole in the file).
CELL_PRECISION = {"score": 4, "lod": 4, "z": 2, "lod_ratio": 2, "p": 6, "q": 6, "top_class_change": 1,
                  **{k: 4 for k in METRIC_KEYS}}


def cell_aliases():
    """{field: the name QGIS shows}: each metric by its display name (delta_KL, d_BD-Img ...,
    read from the metric), the other fields in words."""
    return {"coverage": "coverage", "points_a": "points (earlier)", "points_b": "points (later)",
            "score": "score (ranking metric)", "lod": "level of detection", "z": "z (spreads above the level)",
            "lod_ratio": "x level of detection", "significant_metrics": "significant in",
            **{k: METRIC[k].name for k in METRIC_KEYS},
            "top_class": "class changed most", "top_class_change": "its change (points of share)",
            "classes_changed": "classes changed"}


def cell_rules():
    """[(field values, :class:`~lidar_sig.io.styles.Rule`)] of the cells' style, the legend's
    order: what changed (significant, or appeared or vanished inside the other epoch's
    footprint) outlined near black in a light halo, significant cells labelled with their rank;
    the other compared cells thin grey; appeared and vanished cells and those with too few points
    filled with their state's colour on the one colour scale of change (:data:`CHANGE_SCALE`;
    outline solid where they changed, dashed at a survey's edge); no fill where compared, so
    that the map's colours show through. A rule draws the cells whose fields hold its values."""
    from ..io.styles import Rule, equal

    def rule(label, values, *style, **more):
        return values, Rule(label, equal(**values), *style, **more)

    def uncompared(state, changed):
        other = "earlier" if state == "appeared" else "later"
        label = f"{state} inside the {other} survey: changed" if changed else f"{state} at a survey's edge: not counted"
        colour = state_colour(state)
        return rule(label, {"coverage": state, "changed": int(changed)},
                    SIGNIFICANT_OUTLINE if changed else colour, 0.7 if changed else 0.4, fill=colour,
                    fill_alpha=255, pattern="solid", line="solid" if changed else "dash",
                    halo=CHANGE_SCALE.halo if changed else None)

    return [
        rule("changed significantly (its rank)", {"significant": 1}, SIGNIFICANT_OUTLINE, 0.7, halo=CHANGE_SCALE.halo),
        rule("compared, not significantly changed", {"coverage": "compared", "significant": 0}, (110, 110, 110), 0.2),
        uncompared("appeared", True),
        uncompared("vanished", True),
        uncompared("appeared", False),
        uncompared("vanished", False),
        rule(COVERAGE_MEANS["too few points"], {"coverage": "too few points"}, (110, 110, 110), 0.3, line="dash",
             fill=state_colour("too few points"), fill_alpha=255, pattern="solid"),
    ]


def cells_style(cells=None):
    """The QGIS style of the cells (QML, :func:`cell_rules`), listing only the rules that draw
    one of ``cells`` ([{field: value}]; every rule when not given), the fields by
    :func:`cell_aliases` with :data:`CELL_PRECISION` decimals."""
    from ..io.styles import matches, polygon_qml

    rules = [r for values, r in cell_rules() if cells is None or any(matches(values, c) for c in cells)]
    return polygon_qml(rules, label_expression='if("significant" = 1, "rank", NULL)', aliases=cell_aliases(),
                       precision=CELL_PRECISION)


def level_style(band, values=None):
    """The QGIS style of the change map's GeoTIFF (QML): band ``band`` (lod_ratio) as a
    single-band pseudocolour in the fixed classes :data:`LEVEL_CLASSES`, with the significance
    test the break at 1. The legend lists only the classes that hold one of ``values`` (the
    map's lod_ratio; every class when not given or all NaN): each keeps its bounds and colour, so
    a value takes the same colour on every map (QGIS gives a value the first class it does not
    exceed, and a class left out holds no value of the map)."""
    from ..io.styles import raster_qml

    classes = CHANGE_SCALE.qgis_classes()
    v = np.asarray([] if values is None else values, dtype=np.float64)
    v = v[~np.isnan(v)]
    if len(v):
        lower = [-np.inf] + [bound for bound, _, _ in classes[:-1]]
        classes = [c for c, low in zip(classes, lower) if ((v > low) & (v <= c[0])).any()]
    return raster_qml(band, classes, ramp="discrete", nodata=state_colour("not covered"))


def state_colour(state):
    """The RGB of coverage ``state`` on the one colour scale of change."""
    return CHANGE_SCALE.states[state][0]


def when_style(series, band):
    """The QGIS style of a series' GeoTIFF (QML): band ``band`` ("when") in the PNG map's colour
    of each interval, 0 (compared, never significant) white."""
    from ..io.styles import raster_qml
    from ..reporting.map_image import INTERVALS

    stops = [(0.0, (255, 255, 255), "0: compared, never significantly changed")]
    stops += [(float(k + 1), tuple(INTERVALS[k % len(INTERVALS)]), f"{k + 1}: {series.interval_name(k)}")
              for k in range(len(series.maps))]
    return raster_qml(band, stops, ramp="exact")


def point_change(cm, xy):
    """{name: (values, description)} of the points at ``xy`` ((N, 2) CRS coordinates, the later
    epoch's, B): their cell's score, level of detection and significance
    (:func:`lidar_sig.io.fields.change_fields`); a point outside the compared cells gets NaN and
    0. Withheld and noise points get their cell's change too."""
    from ..io.fields import change_fields

    cells = cm.grid.cell_of(xy)
    inside = cells >= 0
    t = cm.table
    score, lod = np.full(len(cells), np.nan), np.full(len(cells), np.nan)
    significant = np.zeros(len(cells), np.uint16)
    score[inside], lod[inside] = t["score"][cells[inside]], t["lod"][cells[inside]]
    significant[inside] = t["significant"][cells[inside]]
    ranking = METRIC[cm.score].distance_name
    return change_fields(score, lod, significant, ranking)


def _number(value):
    value = float(value)
    return None if np.isnan(value) else value
