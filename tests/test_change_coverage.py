"""The change map's coverage states and wording (issue 33): cells that only one epoch covers are
"appeared" or "vanished" in the GeoTIFF's band, the JSON and the map, never "no data"; the
table's header says how its rows are ordered, and the advice when no cell holds enough points
names the option that fixes the run."""
import importlib.util
import json
import re
import sys

import numpy as np
import pytest

from command_line import run, run_process
from conftest import ROOT, SAMPLES
from lidar_sig.change_map import changes, read_epoch
from lidar_sig.method.cloud import PointCloud

sys.path.insert(0, str(ROOT / "benchmarks"))
ALIGNED = SAMPLES / "epoch2_aligned.laz"
CELL = 8.0


def cropped(tmp_path):
    """The sample pair with A's points west of x0 + 16 m removed (two columns of 8 m cells that
    only B covers) and B's points east of x1 - 16 m removed (two that only A covers), written as
    LAZ; and the x of the two cuts."""
    from edited_epoch import write_las

    a, b = read_epoch(SAMPLES / "epoch1.laz"), read_epoch(ALIGNED)
    x0 = np.floor(min(a.xyz[:, 0].min(), b.xyz[:, 0].min()) / CELL) * CELL
    x1 = np.ceil(max(a.xyz[:, 0].max(), b.xyz[:, 0].max()) / CELL) * CELL
    west, east = x0 + 2 * CELL, x1 - 2 * CELL
    paths = []
    for cloud, keep, name in ((a, a.xyz[:, 0] >= west, "a.laz"), (b, b.xyz[:, 0] < east, "b.laz")):
        part = PointCloud(cloud.xyz[keep], cloud.labels[keep], crs=cloud.crs)
        write_las(part, tmp_path / name)
        paths.append(tmp_path / name)
    return paths, west, east


@pytest.mark.skipif(importlib.util.find_spec("rasterio") is None,
                    reason="rasterio not installed: pip install -e '.[geo]'")
def test_cells_that_only_one_epoch_covers_are_appeared_or_vanished_in_the_geotiff_json_and_map(tmp_path):
    import rasterio

    import cv2

    from lidar_sig.reporting.change_scale import CHANGE_SCALE
    from lidar_sig.reporting.map_image import layout

    APPEARED, VANISHED = (CHANGE_SCALE.states[s][0] for s in ("appeared", "vanished"))

    (a, b), west, east = cropped(tmp_path)
    proc = run_process("changes", a, b, "--cell", str(CELL), "-o", tmp_path / "map.tif", "--png",
                       tmp_path / "map.png", "--json", "--top", "3")
    assert proc.returncode == 0, proc.stderr
    info = json.loads(proc.stdout)
    appeared, vanished = info["coverage"]["appeared"], info["coverage"]["vanished"]
    assert len(appeared) >= 8 and len(vanished) >= 8  # two columns of a 9-row grid, less empty corners
    assert all(c["bounds"][2] <= west and c["points_a"] == 0 and c["points_b"] > 0 for c in appeared)
    assert all(c["bounds"][0] >= east and c["points_b"] == 0 and c["points_a"] > 0 for c in vanished)
    counts = info["coverage"]["cells"]
    assert counts["appeared"] == len(appeared) and counts["vanished"] == len(vanished)
    assert sum(counts.values()) == info["grid"]["cells"] and counts["compared"] == info["grid"]["valid"]
    with rasterio.open(tmp_path / "map.tif") as src:
        band = src.descriptions.index(next(d for d in src.descriptions if d.startswith("coverage:"))) + 1
        assert "appeared" in src.descriptions[band - 1] and "vanished" in src.descriptions[band - 1]
        coverage = src.read(band)
        score = src.read(1)
    codes = {v: int(k) for k, v in info["coverage"]["codes"].items()}
    for cells, state in ((appeared, "appeared"), (vanished, "vanished")):
        for c in cells:
            assert coverage[c["row"], c["col"]] == codes[state]
            assert score[c["row"], c["col"]] == -9999.0  # not compared: no score, but a state
    assert (coverage != -9999.0).all()  # every cell has a state
    # the map paints them in their own colours, not the colour of too few points
    image = cv2.cvtColor(cv2.imread(str(tmp_path / "map.png")), cv2.COLOR_BGR2RGB).astype(float)
    from lidar_sig.change_map import Grid

    a_, b_, c_, d_, e_, f_ = info["grid"]["transform"]
    grid = Grid(c_, f_ - info["grid"]["rows"] * CELL, CELL, info["grid"]["rows"], info["grid"]["cols"])
    lay = layout(grid)
    side = lay.map_w / grid.cols
    for cells, colour in ((appeared, APPEARED), (vanished, VANISHED)):
        for c in (c for c in cells if c["row"] > 0):  # the north arrow covers a corner of row 0
            y = int(lay.map_y + (c["row"] + 0.5) * side)
            x = int(lay.map_x + (c["col"] + 0.5) * side)
            assert (image[y - 2:y + 3, x - 2:x + 3] == colour).all()


def test_coverage_states_follow_the_documented_rule():
    from lidar_sig.change_map._cells import COVERAGE, coverage

    codes = {v: k for k, v in COVERAGE.items()}
    points_a = np.array([500, 0, 400, 80, 49, 0, 3, 30, 1000])
    points_b = np.array([600, 450, 0, 700, 0, 0, 60, 40, 90])
    valid = np.array([True] + [False] * 8)
    # one epoch covers a cell from 50 points, where the other holds less than a tenth as many
    got = coverage(points_a, points_b, valid, 100)
    assert [COVERAGE[int(c)] for c in got] == ["compared", "appeared", "vanished", "too few points", "too few points",
                                               "not covered", "appeared", "too few points", "vanished"]
    # per unit of density: 90 points of a survey ten times sparser are not "almost none"
    assert COVERAGE[int(coverage(points_a, points_b, valid, 100, densities=(10.0, 1.0))[-1])] == "too few points"
    assert codes["compared"] == 1 and codes["not covered"] == 0


def test_rows_are_ordered_as_the_header_says():
    proc = run("changes", SAMPLES / "epoch1.laz", ALIGNED, "--cell", str(CELL), "--top", "30", "-q")
    assert proc.returncode == 0, proc.stderr
    lines = proc.stdout.splitlines()
    header = lines[2]
    assert "rows: significant first, then by how far above its level (lod_ratio" in header
    assert "ranked by" not in header
    n = int(header.split()[0])
    start = next(i for i, line in enumerate(lines) if line.split()[:1] == ["rank"]) + 1
    rows = [line.split() for line in lines[start:]]
    flags = [r[0].endswith("*") for r in rows]
    assert flags == [True] * n + [False] * (len(rows) - n) and n >= 5
    # lod_ratio from the printed columns (score / lod, delta_H / its level; rounded, so a little slack)
    # (a row whose level prints as 0.0000 cannot say its ratio: left out)
    ratio = [max(float(r[5]) / float(r[6]), float(r[7]) / float(r[8])) if float(r[6]) and float(r[8]) else None
             for r in rows]
    for part in (ratio[:n], ratio[n:]):
        part = [r for r in part if r is not None]
        assert all(later <= earlier * 1.01 + 0.01 for earlier, later in zip(part, part[1:])), part
    # the score alone does not order the rows: that is why the header does not say so
    scores = [float(r[5]) for r in rows]
    assert scores != sorted(scores, reverse=True)


def test_the_advice_when_no_cell_holds_enough_points_names_the_option_that_fixes_the_run():
    proc = run("changes", SAMPLES / "epoch1.laz", ALIGNED, "--cell", "0.5", "-q")
    assert proc.returncode == 2 and proc.stdout == ""
    message = proc.stderr.strip()
    assert len(message.splitlines()) == 1 and "use a larger cell size (--cell" in message
    # the advice works: a larger cell gives a map with the same automatic minimum
    proc = run("changes", SAMPLES / "epoch1.laz", ALIGNED, "--cell", "4", "--top", "1", "-q")
    assert proc.returncode == 0, proc.stderr
    assert re.search(r"hold 30 points with defined saliency \(auto\)", proc.stdout)
    # and a smaller one does not
    proc = run("changes", SAMPLES / "epoch1.laz", ALIGNED, "--cell", "0.25", "-q")
    assert proc.returncode == 2 and "larger cell size" in proc.stderr
    # cells larger than the survey: the minimum, a fifth of a full cell, is what a smaller cell fixes
    proc = run("changes", SAMPLES / "epoch1.laz", ALIGNED, "--cell", "500", "-q")
    assert proc.returncode == 2 and "use a smaller cell size (--cell)" in proc.stderr


def test_a_map_of_a_pair_that_only_partly_overlaps_keeps_every_point_in_a_state():
    from lidar_sig.change_map._cells import COVERS

    a, b = read_epoch(SAMPLES / "epoch1.laz"), read_epoch(ALIGNED)
    x = np.median(a.xyz[:, 0])
    b = PointCloud(b.xyz[b.xyz[:, 0] < x + 12], b.labels[b.xyz[:, 0] < x + 12], crs=b.crs)
    cm = changes(a, b, cell=CELL)
    t = cm.table
    states = cm.coverage()
    assert states["vanished"] > 0 and sum(states.values()) == cm.grid.n_cells
    covered = (t["points_a"] > 0) | (t["points_b"] > 0)
    assert np.array_equal(t["coverage"] == 0, ~covered)  # "not covered" only where neither epoch has a point
    least = max(1, int(np.ceil(COVERS * cm.min_points)))
    only_a = (t["points_a"] >= least) & (t["points_b"] / cm.density[1] < 0.1 * t["points_a"] / cm.density[0])
    assert np.array_equal(t["coverage"] == 3, only_a & ~t["valid"])


def test_a_run_below_the_density_where_recall_drops_warns_with_the_figure(tmp_path):
    from edited_epoch import write_las

    from lidar_sig.change_map._density import LEAST_DENSITY, RECALL_BELOW
    from lidar_sig.base.errors import LidarSigWarning

    rng = np.random.default_rng(3)
    paths = []
    for source, name in ((SAMPLES / "epoch1.laz", "a.laz"), (ALIGNED, "b.laz")):
        cloud = read_epoch(source)
        keep = rng.random(len(cloud)) < 0.06  # about 0.5 points/m² of the 8.5 and 6.4 of the sample
        write_las(PointCloud(cloud.xyz[keep], cloud.labels[keep], crs=cloud.crs), tmp_path / name)
        paths.append(tmp_path / name)
    with pytest.warns(LidarSigWarning, match=rf"b\.laz holds 0\.\d+ points/m²: below {LEAST_DENSITY:g} point/m²"):
        cm = changes(*paths, cell=16)
    assert cm.density[1] < LEAST_DENSITY and f"({RECALL_BELOW:.0%} at 0.5 points/m²" in cm.warnings[0]
    proc = run("changes", *paths, "--cell", "16", "--top", "1")
    assert proc.returncode == 0, proc.stderr
    notes = [line for line in proc.stderr.splitlines() if "point/m²" in line]
    assert len(notes) == 1 and notes[0].startswith("lidar-sig: note: ")
    # a survey at or above the figure is not warned about
    dense = changes(SAMPLES / "epoch1.laz", ALIGNED, cell=CELL)
    assert not any("point/m²" in w for w in dense.warnings)


def holed(tmp_path):
    """The sample pair with a square of 2 x 2 cells of A's points removed inside its survey (land
    A covered around them: appeared inside A's footprint, change) and the cut of :func:`cropped`
    on both sides (at the surveys' edges: not change); the paths and the (row, col) of the hole."""
    from edited_epoch import write_las

    (a_path, b_path), west, east = cropped(tmp_path)
    a = read_epoch(a_path)
    x_mid = np.floor((west + east) / 2 / CELL) * CELL
    y_mid = np.floor(np.median(a.xyz[:, 1]) / CELL) * CELL
    hole = ((a.xyz[:, 0] >= x_mid) & (a.xyz[:, 0] < x_mid + 2 * CELL)
            & (a.xyz[:, 1] >= y_mid) & (a.xyz[:, 1] < y_mid + 2 * CELL))
    write_las(PointCloud(a.xyz[~hole], a.labels[~hole], crs=a.crs), tmp_path / "a_holed.laz")
    return (tmp_path / "a_holed.laz", b_path), (x_mid, y_mid)


def test_appeared_and_vanished_land_inside_the_other_survey_is_change_and_its_edge_is_not(tmp_path):
    # issue 38: one count and one layer rule answer "what changed?"
    import sqlite3

    (a, b), (x_mid, y_mid) = holed(tmp_path)
    proc = run("changes", a, b, "--cell", str(CELL), "--cells", tmp_path / "cells.gpkg", "--json", "--top", "0")
    assert proc.returncode == 0, proc.stderr
    info = json.loads(proc.stdout)
    hole = {(c["row"], c["col"]) for c in info["coverage"]["appeared"]
            if x_mid <= c["bounds"][0] < x_mid + 2 * CELL and y_mid <= c["bounds"][1] < y_mid + 2 * CELL}
    assert len(hole) == 4, info["coverage"]["appeared"]
    edge = {(c["row"], c["col"]) for c in info["coverage"]["appeared"] + info["coverage"]["vanished"]} - hole
    assert len(edge) >= 16
    assert all(c["changed"] == ((c["row"], c["col"]) in hole)
               for c in info["coverage"]["appeared"] + info["coverage"]["vanished"])
    moved = info["coverage"]["changed"]
    assert moved == {"appeared": 4, "vanished": 0, "at the edges": len(edge)}
    assert info["grid"]["changed"] == info["grid"]["significant"] + 4
    # the cells layer's "changed": the significant cells and the hole, never the edges
    with sqlite3.connect(tmp_path / "cells.gpkg") as db:
        rows = db.execute("SELECT row, col, changed, significant, coverage FROM cells").fetchall()
    changed = {(r, c) for r, c, ch, _, _ in rows if ch == 1}
    significant = {(r, c) for r, c, _, sig, _ in rows if sig == 1}
    assert changed == significant | hole and not changed & edge
    assert all(ch is None for _, _, ch, _, state in rows if state == "too few points")
    # the summary says the same count
    text = run("changes", a, b, "--cell", str(CELL), "--top", "0", "-q")
    assert text.returncode == 0, text.stderr
    line = next(ln for ln in text.stdout.splitlines() if ln.startswith("changed: "))
    assert line.startswith(f"changed: {len(changed)} cells ({len(significant)} significant, 4 appeared and 0 "
                           f"vanished inside the other epoch's footprint; {len(edge)} at a survey's edge"), line


def test_footprint_holds_the_holes_a_survey_encloses_not_its_edges():
    from lidar_sig.change_map._cells import in_footprint

    # 5 x 5 cells: A present in a ring around the centre, absent in the first column (its edge)
    points_a = np.full((5, 5), 100)
    points_a[2, 2] = 0  # a hole inside A's survey
    points_a[:, 0] = 0  # beyond A's edge
    points_b = np.full((5, 5), 100)
    codes = np.ones((5, 5), np.int8)
    codes[2, 2] = 2
    codes[:, 0] = 2  # appeared
    inside = in_footprint(codes.ravel(), points_a.ravel(), points_b.ravel(), 100, (5, 5)).reshape(5, 5)
    assert inside[2, 2] and not inside[:, 0].any() and not inside[codes == 1].any()
    # a sliver of A's points in an appeared cell does not make it A's land
    points_a[:, 0] = 60
    inside = in_footprint(codes.ravel(), points_a.ravel(), points_b.ravel(), 100, (5, 5)).reshape(5, 5)
    assert not inside[:, 0].any() and inside[2, 2]


def test_p_values_say_significance_and_q_values_are_benjamini_hochberg():
    from statistics import NormalDist

    from lidar_sig.change_map._lod import p_values, pooled_confidence, q_values, quantile

    z = np.array([np.nan, -1.0, 0.5, 2.0, 2.3, 4.0])
    p = p_values(z, 2)
    expected = [min(1.0, 2 * (1 - NormalDist().cdf(v))) for v in z[1:]]
    assert np.isnan(p[0]) and np.allclose(p[1:], expected)
    # significant at 95% over two tests exactly where p < 5%
    threshold = quantile(pooled_confidence(0.95, 2))
    assert list(p[1:] < 0.05) == list(z[1:] > threshold)
    # the step down from the larger p-values and the cap at 1, by hand
    assert np.allclose(q_values([0.04, 0.03, 0.01, np.nan])[:3], [0.04, 0.04, 0.03])
    assert np.allclose(q_values([0.9, 0.8]), [0.9, 0.9]) and q_values([1.0, 0.99])[1] == 1.0
    q = q_values(p)
    m = 5
    order = np.argsort(p[1:])
    by_hand = np.array([p[1:][order][i] * m / (i + 1) for i in range(m)])
    by_hand = np.minimum.accumulate(by_hand[::-1])[::-1]
    assert np.isnan(q[0]) and np.allclose(q[1:][order], np.minimum(by_hand, 1.0))
    assert (q[1:] >= p[1:]).all()


def test_the_ign_block_s_overlapping_strips_are_quiet_and_their_edges_are_not_change():
    # issue 38: two passes over the same land (real occlusions, scan angles, strip offsets)
    import math

    from conftest import IGN, need_data
    from strip_nulls import BLOCKS, strip_pair, strips

    need_data(IGN)
    found = strips(BLOCKS["IGN block"])
    assert sorted(found) == [706, 707]
    figures = strip_pair(found[706], found[707])
    assert figures["compared"] >= 10, figures
    # flagged no more often than the 95% level lets unchanged land be, and no strip edge is change
    assert figures["changed"] <= math.ceil(0.05 * figures["compared"]), figures
    assert figures["coverage changed"] == 0 and figures["at the edges"] > 0, figures


def test_a_bay_open_at_a_corner_and_a_gap_larger_than_a_hectare_are_not_the_survey_s_land():
    # a hole joined to the outside by one diagonal step is an edge; a hole over HOLE_M2 is a gap
    # in the survey (a tile missing from a delivery), not land that changed
    from lidar_sig.change_map._cells import HOLE_M2, in_footprint

    def appeared_inside(absent, shape, cell_m=None):
        points_a = np.full(shape, 100)
        codes = np.ones(shape, np.int8)
        for r, c in absent:
            points_a[r, c] = 0
            codes[r, c] = 2
        inside = in_footprint(codes.ravel(), points_a.ravel(), np.full(shape, 100).ravel(), 100, shape, cell_m)
        return {(r, c) for r, c in absent if inside.reshape(shape)[r, c]}

    bay = [(1, 1), (1, 2), (2, 1), (2, 2)]
    assert appeared_inside(bay + [(0, 0)], (6, 6)) == set()  # open through the corner (0, 0)
    assert appeared_inside(bay, (6, 6)) == set(bay)  # closed: the survey's land
    gap = [(r, c) for r in range(3, 8) for c in range(3, 8)]  # 5 x 5 cells
    assert HOLE_M2 < 25 * 25.0 ** 2  # 25 cells of 25 m: more than a hectare
    assert appeared_inside(gap, (12, 12), cell_m=25.0) == set()
    assert appeared_inside(gap, (12, 12), cell_m=10.0) == set(gap)  # 0.25 ha: land that changed


def test_an_epoch_given_as_a_glob_or_a_virtual_point_cloud_gives_the_map_of_its_files(tmp_path):
    # issue 37: epochs as a glob pattern of tiles or a .vpc (a STAC ItemCollection, as QGIS and PDAL write)
    import shutil

    tiles = tmp_path / "tiles"
    tiles.mkdir()
    shutil.copyfile(ALIGNED, tiles / "later.laz")
    vpc = tiles / "later.vpc"
    vpc.write_text(json.dumps({"type": "FeatureCollection", "features": [
        {"type": "Feature", "stac_version": "1.0.0", "assets": {"data": {"href": "./later.laz", "roles": ["data"]}}}]}))
    answers = []
    for later in (ALIGNED, tiles / "lat*.laz", vpc):
        done = run("changes", SAMPLES / "epoch1.laz", later, "--cell", str(CELL), "--json", "--top", "100000")
        assert done.returncode == 0, done.stderr
        info = json.loads(done.stdout)
        answers.append((info["grid"], [(c["row"], c["col"], c["score"], c["significant"]) for c in info["top"]]))
    assert answers[1] == answers[0] and answers[2] == answers[0]
    # a pattern that matches nothing, and a .vpc that lists a missing tile: one line naming them
    from robustness.helpers import assert_one_line_error

    assert_one_line_error(run("changes", SAMPLES / "epoch1.laz", tiles / "*.las"), "*.las", "matches no")
    vpc.write_text(vpc.read_text().replace("later.laz", "gone.laz"))
    assert_one_line_error(run("changes", SAMPLES / "epoch1.laz", vpc), "later.vpc", "gone.laz")
