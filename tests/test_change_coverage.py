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

    from lidar_sig.reporting.map_image import APPEARED, VANISHED, layout

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
    # the map paints them in their own colours (blended over the backdrop), not the grey of too few points
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
            pixel = image[y - 2:y + 3, x - 2:x + 3].reshape(-1, 3).mean(axis=0)
            # the blend's direction from white is the state's colour's
            assert np.corrcoef(255 - pixel, 255 - np.asarray(colour, float))[0, 1] > 0.9


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
    assert "rows: significant first, then by z" in header and "ranked by" not in header
    n = int(header.split()[0])
    rows = [line.split() for line in lines[4:]]
    z = [float(r[9]) for r in rows]
    flags = [r[0].endswith("*") for r in rows]
    assert flags == [True] * n + [False] * (len(rows) - n) and n >= 5
    assert z[:n] == sorted(z[:n], reverse=True) and z[n:] == sorted(z[n:], reverse=True)
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
