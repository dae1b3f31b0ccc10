"""The change map at survey scale (issue 37): epochs of tiles cut on different grids, mapped in
work units within a memory budget, on local processes or a Dask cluster, give the map of one
block; an interrupted run resumes to the same map; the per-point change streams."""
import sys
from pathlib import Path

import laspy
import numpy as np
import pytest

import lidar_sig as ls
from conftest import IGN_FILES, ROOT
from lidar_sig.change_map import changes, read_epoch
from lidar_sig.method.cloud import PointCloud
from lidar_sig.tiling.execution import Execution

sys.path.insert(0, str(ROOT / "benchmarks"))
pytestmark = pytest.mark.skipif(not IGN_FILES, reason="the IGN tiles of ../shared/data are not beside the project")


@pytest.fixture(scope="module")
def regridded(tmp_path_factory):
    """Epoch A: the six IGN tiles as they are. Epoch B: the block edited (a building removed,
    vegetation removed, a box building added; benchmarks/edited_epoch.py), 80% kept, moved,
    and cut into 4 tiles on another grid (split at the block's middle, 37 m and 61 m off the IGN
    tiles' 50 m edges). And the one-block map of the two."""
    from edited_epoch import edit, write_las

    folder = tmp_path_factory.mktemp("regridded")
    one = read_epoch(list(IGN_FILES))
    two, edits = edit(one)
    x_cut, y_cut = np.median(two.xyz[:, 0]) + 13.0, np.median(two.xyz[:, 1]) - 11.0
    tiles = []
    for k, (east, north) in enumerate(((0, 0), (0, 1), (1, 0), (1, 1))):
        part = ((two.xyz[:, 0] >= x_cut) == bool(east)) & ((two.xyz[:, 1] >= y_cut) == bool(north))
        tiles.append(folder / f"b_{k}.laz")
        write_las(PointCloud(two.xyz[part], two.labels[part], crs=one.crs), tiles[-1])
    pipe = ls.Pipeline(progress=False)
    whole = changes(list(IGN_FILES), tiles, pipeline=pipe)
    return tiles, edits, whole


def assert_same_map(got, want):
    """The same cells, metrics within float tolerance, levels, verdicts and ranking."""
    a, b = want.table, got.table
    assert a.dtype == b.dtype
    for k in a.dtype.names:
        if a.dtype[k].kind == "f":
            np.testing.assert_allclose(b[k], a[k], rtol=1e-7, atol=1e-12, equal_nan=True, err_msg=k)
        else:
            assert np.array_equal(b[k], a[k]), k
    assert np.array_equal(got.classes_a, want.classes_a) and np.array_equal(got.classes_b, want.classes_b)
    assert got.grid == want.grid and got.cell == want.cell and got.min_points == want.min_points
    assert got.density == pytest.approx(want.density, rel=1e-12)
    assert got.score == want.score and got.method == want.method
    for k, level in want.levels.items():
        assert got.levels[k].beta == pytest.approx(level.beta, rel=1e-9, abs=1e-12), k
        assert got.levels[k].tau == pytest.approx(level.tau, rel=1e-9, abs=1e-12), k
    assert np.array_equal(got.ranked(), want.ranked())
    assert got.n_changed == want.n_changed and got.coverage() == want.coverage()
    assert got.warnings == want.warnings  # the same notes, in the same order


def test_tiles_cut_on_another_grid_in_work_units_give_the_one_block_map(regridded, tmp_path):
    tiles, edits, whole = regridded
    cm = changes(list(IGN_FILES), tiles, pipeline=ls.Pipeline(progress=False),
                 execution=Execution(memory="400MiB", workers=2, tile_size=60.0), work=tmp_path / "work")
    try:
        assert cm.timings["units"]["units"] >= 4  # several work units, on two processes
        assert_same_map(cm, whole)
        assert whole.n_significant >= 2  # the edits are there to be found, in both
        for flat in cm.ranked(3):  # a cell's signatures are read back from its work unit
            for s_units, s_whole in zip(cm.signatures(int(flat)), whole.signatures(int(flat))):
                assert np.array_equal(s_units.counts, s_whole.counts)
        xyz, values = cm.b.view()
        assert 0 < len(xyz) <= cm.b.n_points and values.shape == (len(xyz), 3)
    finally:
        cm.close()
    assert not (tmp_path / "work").exists()
    with pytest.raises(ls.LidarSigError, match="work folder was removed"):
        cm.signatures(int(cm.ranked(1)[0]))


def test_a_dask_cluster_gives_the_map_of_local_processes(regridded, tmp_path):
    distributed = pytest.importorskip("distributed", reason="the dask extra is not installed")
    tiles, _, whole = regridded
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=None) as cluster:
        cm = changes(list(IGN_FILES), tiles, pipeline=ls.Pipeline(progress=False),
                     execution=Execution(memory="400MiB", scheduler=cluster.scheduler_address))
    try:
        assert_same_map(cm, whole)
    finally:
        cm.close()


def test_an_interrupted_run_resumes_to_the_same_map(regridded, tmp_path, monkeypatch):
    from lidar_sig.change_map import _units

    tiles, _, whole = regridded
    work = tmp_path / "work"
    calls = []
    real = _units.unit_task

    def fails_third(uplan, unit, tiles_of):
        calls.append(unit)
        if len(calls) == 3:
            raise KeyboardInterrupt  # as Ctrl-C in the middle of the units
        return real(uplan, unit, tiles_of)

    monkeypatch.setattr(_units, "unit_task", fails_third)
    monkeypatch.setattr("lidar_sig.change_map._in_units.unit_task", fails_third)
    options = dict(pipeline=ls.Pipeline(progress=False), execution=Execution(memory="400MiB", workers=1,
                                                                              tile_size=60.0), work=work)
    with pytest.raises(KeyboardInterrupt):
        changes(list(IGN_FILES), tiles, **options)
    assert work.is_dir() and len(list((work / "units").glob("u*.npz"))) == 2  # what was finished is kept
    done = sorted(p.stat().st_mtime_ns for p in (work / "units").glob("u*.npz"))
    calls.clear()
    monkeypatch.setattr(_units, "unit_task", real)
    monkeypatch.setattr("lidar_sig.change_map._in_units.unit_task", real)
    cm = changes(list(IGN_FILES), tiles, resume=True, **options)
    try:
        assert_same_map(cm, whole)
        kept = sorted(p.stat().st_mtime_ns for p in (work / "units").glob("u*.npz"))
        assert set(done) <= set(kept)  # the finished units were reused, not computed again
    finally:
        cm.close()


@pytest.mark.parametrize("task", ["density_task", "code_task", "unit_task"])
def test_a_failed_task_keeps_the_map_s_own_work_folder_and_says_how_to_resume(regridded, monkeypatch, task):
    # in Python without work=, a unit that failed (a full disk, say) named the folder "kept for
    # a resumed run", then removed it with the rest of the map's own temporary work; a failed
    # density named an epoch's subfolder, from which a resumed run would start again
    from lidar_sig.change_map import _in_units

    tiles, _, whole = regridded
    real = getattr(_in_units, task)
    calls = []

    def fails_second(*args):
        calls.append(args)
        if len(calls) == 2:
            raise OSError(28, "No space left on device")
        return real(*args)

    monkeypatch.setattr(_in_units, task, fails_second)
    options = dict(pipeline=ls.Pipeline(progress=False), execution=Execution(memory="400MiB", workers=1,
                                                                              tile_size=60.0))
    with pytest.raises(ls.LidarSigError, match=r"No space left on device.*resume=True, work=") as caught:
        changes(list(IGN_FILES), tiles, **options)
    assert caught.value.path is not None
    work = Path(caught.value.path)
    assert work.is_dir() and (work / "epoch_a").is_dir()  # the map's folder, not an epoch's
    if task == "unit_task":
        assert len(list((work / "units").glob("u*.npz"))) == 1  # the unit finished before is kept
    monkeypatch.setattr(_in_units, task, real)
    cm = changes(list(IGN_FILES), tiles, resume=True, work=work, **options)
    try:
        assert_same_map(cm, whole)
    finally:
        cm.close()
    assert not work.exists()


def test_the_per_point_change_streams_as_the_one_block_writes_it(regridded, tmp_path):
    from edited_epoch import write_las

    tiles, _, _ = regridded
    b = tmp_path / "b.laz"
    write_las(read_epoch(tiles), b)
    pipe = ls.Pipeline(progress=False)
    whole = changes(list(IGN_FILES), b, pipeline=pipe)
    cm = changes(list(IGN_FILES), b, pipeline=pipe, execution=Execution(memory="400MiB", workers=1, tile_size=60.0))
    try:
        whole.save(tmp_path / "whole.laz")
        cm.save(tmp_path / "units.laz")
    finally:
        cm.close()
    got, want = laspy.read(tmp_path / "units.laz"), laspy.read(tmp_path / "whole.laz")
    assert len(got.points) == len(want.points)
    for name in ("ChangeScore", "ChangeLoD", "ChangeSignificant", "Cl", "Cs", "Cp"):
        np.testing.assert_allclose(np.asarray(got[name], float), np.asarray(want[name], float), rtol=1e-6,
                                   equal_nan=True, err_msg=name)


def test_the_command_maps_the_cells_on_every_core_as_one_process_does(regridded):
    # the command line forks the cells' work (a process of one thread); under the test runner
    # (threads of its own) the same map is made in this process, cell after cell
    import json
    import os

    from command_line import run_process

    tiles, _, _ = regridded
    done = run_process("changes", IGN_FILES[0].parent, tiles[0].parent, "--cell", "10", "--json", "--top", "100000",
                       "--verbose")
    assert done.returncode == 0, done.stderr[-2000:]
    forked = json.loads(done.stdout)
    here = changes(IGN_FILES[0].parent, tiles[0].parent, cell=10, pipeline=ls.Pipeline(progress=False))
    assert forked["grid"]["valid"] >= 32  # cells enough for two processes
    processes = max(1, min(len(os.sched_getaffinity(0)), forked["grid"]["valid"] // 16))
    assert f"processes {processes}," in done.stderr or f"processes {processes})" in done.stderr
    want = json.loads(json.dumps(here.to_dict(100000)))
    for key in ("grid", "levels", "top"):
        assert forked[key] == want[key], key


def _vpc(path, tiles):
    """A .vpc (STAC ItemCollection, as QGIS and PDAL write) listing ``tiles``."""
    import json

    path.write_text(json.dumps({"type": "FeatureCollection", "features": [
        {"type": "Feature", "assets": {"data": {"href": str(p), "roles": ["data"]}}} for p in tiles]}))
    return path


def test_the_map_is_the_same_however_an_epoch_is_ordered_cut_or_listed(regridded, tmp_path):
    # issue 47: the resamples draw a cell's points by their own key, not by their position, so
    # the points of B in one file, shuffled in another, cut into tiles on another grid or listed
    # by a .vpc, in one block or in work units, give the same z, levels, p-values and ranking
    from edited_epoch import write_las

    tiles, _, _ = regridded
    parts = [ls.read(t) for t in tiles]
    xyz, labels = np.vstack([p.xyz for p in parts]), np.concatenate([p.labels for p in parts])
    crs = parts[0].crs
    order = np.random.default_rng(3).permutation(len(xyz))
    whole_file, shuffled_file = tmp_path / "b.laz", tmp_path / "b_shuffled.laz"
    write_las(PointCloud(xyz, labels, crs=crs), whole_file)
    write_las(PointCloud(xyz[order], labels[order], crs=crs), shuffled_file)
    a_shuffled = tmp_path / "a_shuffled.laz"
    one = read_epoch(list(IGN_FILES))
    turned = np.random.default_rng(4).permutation(len(one.xyz))
    write_las(PointCloud(one.xyz[turned], one.labels[turned], crs=one.crs), a_shuffled)
    pipe = ls.Pipeline(progress=False)
    want = changes(list(IGN_FILES), whole_file, pipeline=pipe)
    assert want.n_significant >= 2  # the edits are there to be found
    units = Execution(memory="400MiB", workers=2, tile_size=60.0)
    variants = {
        "B shuffled, one block": lambda: changes(list(IGN_FILES), shuffled_file, pipeline=pipe),
        "A shuffled in one file, B in tiles on another grid, one block": lambda: changes(a_shuffled, tiles, pipeline=pipe),
        "B listed by a .vpc, work units": lambda: changes(list(IGN_FILES), _vpc(tmp_path / "b.vpc", tiles),
                                                          pipeline=pipe, execution=units, work=tmp_path / "w1"),
        "A shuffled, B shuffled, work units": lambda: changes(a_shuffled, shuffled_file, pipeline=pipe,
                                                              execution=units, work=tmp_path / "w2"),
    }
    for name, make in variants.items():
        got = make()
        try:
            # the verdicts and the ranking exactly; the values within float noise: a point read from a
            # file written with other offsets differs in its last bits (its height by about 1e-13)
            for k in ("significant", "changed", "valid", "coverage", "points_a", "points_b"):
                np.testing.assert_array_equal(got.table[k], want.table[k], err_msg=f"{name}: {k}")
            for k in ("z", "p", "q", "lod", "height_lod", "score", "lod_ratio"):
                np.testing.assert_allclose(got.table[k], want.table[k], rtol=1e-9, atol=1e-12, equal_nan=True,
                                           err_msg=f"{name}: {k}")
            assert np.array_equal(got.ranked(), want.ranked()), name
            assert_same_map(got, want)
        finally:
            got.close()
