"""Tiled processing with halos: the same results as the single-block run (issue 12)."""
import hashlib
import json
import shutil
from pathlib import Path

import h5py
import laspy
import numpy as np
import pytest

import lidar_sig as ls
from lidar_sig.method.classes import class_table
from lidar_sig.base.errors import LidarSigError, LidarSigWarning
from lidar_sig.io.fields import saliency_fields
from lidar_sig.method.signature_raster import Signature
from lidar_sig.tiling._core import saliency_in_tiles
from lidar_sig.tiling.backends import executor
from lidar_sig.tiling.run_set import run_set

from command_line import run as lidar_sig_cli
from conftest import DATA, IGN, IGN_FILES, NOISY, SAMPLES, airborne_like, need_data, noisy_las

# Points tied at the same distance from a query can be listed in another order in a tile's
# voxel grid than in the whole cloud's: the covariance then sums the same terms in another
# order and the last bits can differ. Everything else is the same computation.
ROUND_OFF = 1e-12


def assert_same_saliency(tiled, single):
    assert np.array_equal(np.isnan(tiled.values), np.isnan(single.values))
    ok = ~np.isnan(single.values)
    assert np.max(np.abs(tiled.values[ok] - single.values[ok]), initial=0.0) <= ROUND_OFF
    if single.optimal_scale is None:
        assert tiled.optimal_scale is None
    else:
        assert np.array_equal(tiled.optimal_scale, single.optimal_scale)


def counts_of(sal, labels):
    table = class_table("asprs")
    return Signature.from_saliency(sal.values, table.index(labels), classes=table).counts


@pytest.mark.parametrize("strategy", ["multiscale", "optimal"])
def test_ahn3_cut_4x4_gives_the_single_block_saliency_and_signature(strategy, default_run):
    path = DATA / "ahn3_delft" / "ahn3_cropped_1.laz"
    pipe = ls.Pipeline(strategy=strategy, progress=False)
    if strategy == "multiscale":  # the defaults' run, shared with other tests
        cloud, single = default_run(path).cloud, default_run(path).saliency
    else:
        cloud = ls.read(need_data(path))
        single, _ = pipe.saliency(cloud)
    side = float(np.max(np.ptp(cloud.xyz[:, :2], axis=0))) / 4
    tiled, stats = saliency_in_tiles(pipe, cloud, side)
    assert stats["n_tiles"] == 16 and stats["n_points"] == len(cloud)
    assert_same_saliency(tiled, single)
    assert np.array_equal(counts_of(tiled, cloud.labels), counts_of(single, cloud.labels))


@pytest.mark.parametrize("scales,weights", [(ls.knn(8, 16), "area"),
                                            (ls.radii(0.03, 0.05, units="normalized"), "area"),
                                            (ls.radii(2.0, 3.0), "none")])
def test_a_halo_too_narrow_is_widened_point_by_point_never_wrong(scales, weights):
    xyz, labels = airborne_like(3000, seed=3)
    xyz = np.vstack([xyz, xyz[:50]])  # exact duplicates, merged into one location
    cloud = ls.PointCloud(xyz + [500_000.0, 6_000_000.0, 0.0], np.concatenate([labels, labels[:50]]))
    pipe = ls.Pipeline(scales=scales, weights=weights, progress=False)
    single, _ = pipe.saliency(cloud)
    tiled, stats = saliency_in_tiles(pipe, cloud, 7.0, halo=0.2)
    assert stats["n_recomputed"] > 0  # the 0.2 m halo cannot hold the neighbourhoods
    assert_same_saliency(tiled, single)


def test_tiles_refuse_a_descriptor_that_needs_the_whole_cloud():
    xyz, labels = airborne_like(500)
    with pytest.raises(LidarSigError, match="t3dvt-get.*tiles"):
        saliency_in_tiles(ls.Pipeline("t3dvt-get", progress=False), ls.PointCloud(xyz, labels), 10.0)


@pytest.fixture(scope="module")
def ign_merged():
    """The six IGN tiles read one by one, and their merge run as one block."""
    need_data(IGN)  # (IGN_FILES is empty without it)
    files = [need_data(f) for f in IGN_FILES]
    clouds = [ls.read(f) for f in files]
    merged = ls.PointCloud(np.vstack([c.xyz for c in clouds]), np.concatenate([c.labels for c in clouds]),
                           crs=clouds[0].crs)
    return clouds, ls.Pipeline(progress=False).run(merged)


@pytest.fixture(scope="module")
def ign_set(tmp_path_factory, ign_merged):
    """The IGN folder run as a set of tiles in this process (40 m tiles across the files)."""
    work = tmp_path_factory.mktemp("ign") / "work"
    return run_set(ls.Pipeline(progress=False), [IGN], work=work, tile_size=40.0)


def test_ign_folder_in_tiles_gives_the_signature_and_saliency_of_the_merge(ign_merged, ign_set):
    clouds, merged = ign_merged
    run = ign_set
    assert run.complete and run.tiling.shape == (4, 3)
    assert np.array_equal(run.signature.counts, merged.signature.counts)
    assert np.array_equal(run.signature.egeom_counts, merged.signature.egeom_counts)
    assert np.array_equal(run.signature.class_totals, merged.signature.class_totals)
    assert run.signature.metadata["n_duplicates"] == merged.metadata["n_duplicates"]
    start = 0
    for source, cloud in zip(run.sources, clouds):
        single = merged.saliency.values[start:start + len(cloud)]
        start += len(cloud)
        assert_same_saliency(run.saliency_of(source), ls.Saliency.from_values(single))


def test_a_local_dask_cluster_gives_the_same_results_as_the_local_run(tmp_path, ign_set):
    distributed = pytest.importorskip("distributed", reason="the dask extra is not installed")
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=None) as cluster:
        backend = executor(scheduler=cluster.scheduler_address)
        try:
            run = run_set(ls.Pipeline(progress=False), [IGN], work=tmp_path / "work", tile_size=40.0,
                          backend=backend)
        finally:
            backend.close()
    assert run.complete and "2 workers" in run.execution
    assert np.array_equal(run.signature.counts, ign_set.signature.counts)
    for a, b in zip(run.sources, ign_set.sources):
        assert np.array_equal(run.saliency_of(a).values, ign_set.saliency_of(b).values, equal_nan=True)


@pytest.mark.parametrize("keep_noise", [False, True])
def test_withheld_and_noise_points_are_left_out_of_tiles_as_of_the_single_block(tmp_path, keep_noise):
    path = tmp_path / "noisy.laz"
    scene = noisy_las(path, n=6000)
    cloud = ls.read(path)
    pipe = ls.Pipeline(progress=False, keep_noise=keep_noise)
    single = pipe.run(cloud)
    assert single.metadata["n_excluded"] == (0 if keep_noise else sum(NOISY.values()))
    tiled, stats = saliency_in_tiles(pipe, cloud, 15.0)
    assert_same_saliency(tiled, single.saliency)
    assert stats["n_excluded"] == single.metadata["n_excluded"]
    run = run_set(pipe, [path], work=tmp_path / "work", tile_size=15.0)
    assert run.complete and run.tiling.shape[0] > 2
    assert_same_saliency(run.saliency_of(run.sources[0]), single.saliency)
    for key in ("counts", "egeom_counts", "class_totals"):
        assert np.array_equal(getattr(run.signature, key), getattr(single.signature, key)), key
    for key in ("n_points", "n_undefined", "n_excluded", "n_duplicates"):
        assert run.signature.metadata[key] == single.metadata[key], key
    out = tmp_path / "out.laz"
    assert run.write_points(run.sources[0], out)
    las = laspy.read(out)
    assert len(las.points) == len(cloud) and np.isnan(np.asarray(las["Cl"])[~scene]).all() != keep_noise


def test_a_file_cut_off_mid_file_is_named_the_others_written_and_resume_completes_the_set(tmp_path, ign_set):
    folder = tmp_path / "tiles"
    folder.mkdir()
    for f in IGN_FILES:
        shutil.copyfile(need_data(f), folder / f.name)
    cut = folder / IGN_FILES[2].name
    cut.write_bytes(IGN_FILES[2].read_bytes()[:120_000])  # the header is whole, the points stop short
    out = tmp_path / "out"
    args = ("saliency", folder, "-o", out, "--workers", "1", "--tile-size", "50")
    first = lidar_sig_cli(*args)
    assert first.returncode == 1, first.stderr
    assert f"missing: {cut.name}" in first.stderr and "--resume" in first.stderr
    assert "Traceback" not in first.stderr
    assert sorted(p.name for p in out.glob("*.laz")) == sorted(f.name for f in IGN_FILES if f.name != cut.name)
    again = lidar_sig_cli(*args, "--resume")  # still cut off: finished tiles are reused
    assert again.returncode == 1 and "6 reused" in again.stdout, again.stdout
    shutil.copyfile(IGN_FILES[2], cut)
    done = lidar_sig_cli(*args, "--resume")
    assert done.returncode == 0, done.stderr
    assert not (out / ".lidar-sig-work").exists()
    for source in ign_set.sources:  # the set's results, now with every file
        written = laspy.read(out / source.name)
        expected = ign_set.saliency_of(source).values.astype(np.float32)
        got = np.column_stack([written["Cl"], written["Cs"], written["Cp"]])
        assert np.allclose(got, expected, rtol=0, atol=1e-6, equal_nan=True)


def test_signature_of_a_folder_records_the_tiling_and_every_file_with_its_sha256(tmp_path, ign_set):
    out = tmp_path / "set.h5"
    proc = lidar_sig_cli("signature", IGN, "-o", out, "--workers", "2", "--tile-size", "40")
    assert proc.returncode == 0, proc.stderr
    assert "12 tiles of 40 m" in proc.stdout and "points/s" in proc.stdout
    sig = ls.load_signature(out)
    assert np.array_equal(sig.counts, ign_set.signature.counts)
    with h5py.File(out) as f:
        sources = json.loads(f.attrs["sources"])
        tiling = json.loads(f.attrs["tiling"])
    assert [Path(s["path"]).name for s in sources] == [f.name for f in IGN_FILES]
    assert all(s["sha256"] == hashlib.sha256(Path(s["path"]).read_bytes()).hexdigest() for s in sources)
    assert tiling["tiles"] == [4, 3] and tiling["tile_size_m"] == 40.0


@pytest.mark.parametrize("name", ["isprs_filtertest/samp11-utm.laz", "copc/test_data_77050_627755.copc.laz"])
def test_output_streamed_in_chunks_is_the_same_file_as_written_whole(tmp_path, name):
    from lidar_sig.io.las import write_las, write_las_chunks

    src = need_data(DATA / name)
    cloud = ls.read(src)
    pipe = ls.Pipeline(strategy="optimal", progress=False)
    sal, _ = pipe.saliency(cloud)
    with pytest.warns(LidarSigWarning):  # LAS 1.2 upgraded, COPC index dropped: said either way
        write_las(tmp_path / "whole.laz", cloud, saliency_fields(sal, "knn", pipe.scales.values))
    with pytest.warns(LidarSigWarning):
        write_las_chunks(tmp_path / "chunks.laz", src,
                         lambda a, b: ls.Saliency.from_values(sal.values[a:b], sal.optimal_scale[a:b]),
                         scale_kind="knn", scale_values=pipe.scales.values, chunk_points=10_000)
    assert (tmp_path / "whole.laz").read_bytes() == (tmp_path / "chunks.laz").read_bytes()


def test_compare_takes_a_folder_as_one_epoch(tmp_path):
    epoch = tmp_path / "epoch1"
    epoch.mkdir()
    (epoch / "epoch1.laz").symlink_to(SAMPLES / "epoch1.laz")
    proc = lidar_sig_cli("compare", epoch, SAMPLES / "epoch1.laz", "--workers", "1", "--json")
    assert proc.returncode == 0, proc.stderr
    metrics = json.loads(proc.stdout)
    assert metrics["ssim"] == pytest.approx(1.0) and metrics["l1"] == 0 and metrics["bhattacharyya"] == 0


@pytest.mark.parametrize("args, name", [
    (("saliency", SAMPLES, "-o", "out.laz"), "out.laz"),               # a set writes into a folder
    (("saliency", SAMPLES / "epoch1.laz", SAMPLES / "missing", "-o", "out"), "missing"),  # no such input
    (("signature", SAMPLES / "epoch1.laz", SAMPLES / "epoch1.laz", "-o", "x.h5"), "given twice"),
    (("saliency", SAMPLES / "epoch1.laz", "-o", "out", "--workers", "0"), "--workers"),
])
def test_a_set_refuses_bad_arguments_in_one_line_before_any_work(tmp_path, args, name):
    proc = lidar_sig_cli(*args, cwd=tmp_path)
    assert proc.returncode == 2, proc.stderr
    assert len(proc.stderr.strip().splitlines()) == 1 and name in proc.stderr and "Traceback" not in proc.stderr
    assert list(tmp_path.iterdir()) == []


def test_one_file_read_in_parts_and_chunks_gives_the_single_block_result(tmp_path, monkeypatch):
    from lidar_sig.tiling import sources

    monkeypatch.setattr(sources, "PART_POINTS", 10_000)  # 5 parts, each read from its own offset
    monkeypatch.setattr(sources, "CHUNK_POINTS", 3_000)
    pipe = ls.Pipeline(strategy="optimal", progress=False)
    run = run_set(pipe, [SAMPLES / "epoch1.laz"], work=tmp_path / "work", tile_size=25.0)
    single = pipe.run(SAMPLES / "epoch1.laz")
    assert len(run.sources[0].parts()) == 5
    assert np.array_equal(run.signature.counts, single.signature.counts)
    assert_same_saliency(run.saliency_of(run.sources[0]), single.saliency)


def test_resume_on_another_tile_size_restages_and_loses_no_point(tmp_path):
    # staged parts are filed by a grid that follows the tile size: one staged on another grid
    # must be read again, not looked up under the new grid's cell names
    pipe = ls.Pipeline(progress=False)
    work = tmp_path / "work"
    first = run_set(pipe, [SAMPLES / "epoch1.laz"], work=work, tile_size=30.0)
    again = run_set(pipe, [SAMPLES / "epoch1.laz"], work=work, tile_size=17.0, resume=True)
    single = pipe.run(SAMPLES / "epoch1.laz")
    for run in (first, again):
        assert run.complete and np.array_equal(run.signature.counts, single.signature.counts)
    assert_same_saliency(again.saliency_of(again.sources[0]), single.saliency)


def _copies(folder, *sources):
    folder.mkdir()
    for s in sources:
        shutil.copyfile(s, folder / Path(s).name)
    return folder


def test_a_work_folder_that_is_or_holds_an_output_is_refused_before_any_work(tmp_path):
    tiles = _copies(tmp_path / "tiles", SAMPLES / "epoch1.laz", SAMPLES / "epoch2.laz")
    before = {p.name: p.read_bytes() for p in tiles.iterdir()}
    proc = lidar_sig_cli("saliency", tiles, "-o", tmp_path / "out", "--work-dir", tmp_path / "out", "--workers", "1")
    assert proc.returncode == 2 and "--work-dir" in proc.stderr and len(proc.stderr.strip().splitlines()) == 1, \
        proc.stderr
    assert not (tmp_path / "out").exists()
    (tmp_path / "d").mkdir()
    proc = lidar_sig_cli("signature", tiles, "-o", tmp_path / "d" / "set.h5", "--work-dir", tmp_path / "d",
                         "--workers", "1")
    assert proc.returncode == 2 and "--work-dir" in proc.stderr, proc.stderr
    assert list((tmp_path / "d").iterdir()) == []
    assert {p.name: p.read_bytes() for p in tiles.iterdir()} == before


def test_a_set_never_writes_over_its_inputs_nor_two_outputs_on_one_file(tmp_path):
    tiles = _copies(tmp_path / "tiles", SAMPLES / "epoch1.laz")
    other = tmp_path / "other"
    other.mkdir()
    shutil.copyfile(SAMPLES / "epoch2.laz", other / "epoch1.laz")  # another tile of the same name
    before = (tiles / "epoch1.laz").read_bytes()
    proc = lidar_sig_cli("saliency", tiles, "-o", tiles, "--overwrite", "--workers", "1")
    assert proc.returncode == 2 and "over its input" in proc.stderr, proc.stderr
    assert (tiles / "epoch1.laz").read_bytes() == before and sorted(p.name for p in tiles.iterdir()) == ["epoch1.laz"]
    proc = lidar_sig_cli("saliency", tiles, other, "-o", tmp_path / "out", "--workers", "1")
    assert proc.returncode == 2 and "same file name" in proc.stderr, proc.stderr
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("size", ["0", "-5", "nan", "inf", "0.001"])
def test_a_bad_tile_size_is_one_line_before_any_work(tmp_path, size):
    proc = lidar_sig_cli("signature", SAMPLES / "epoch1.laz", "-o", tmp_path / "s.h5", "--tile-size", size,
                         "--workers", "1")
    assert proc.returncode == 2 and len(proc.stderr.strip().splitlines()) == 1, proc.stderr
    assert "tile" in proc.stderr and "Traceback" not in proc.stderr
    assert list(tmp_path.iterdir()) == []


def test_a_set_refuses_an_empty_file_and_files_in_another_crs(tmp_path):
    from robustness.helpers import write_las

    tiles = _copies(tmp_path / "tiles", SAMPLES / "epoch1.laz")
    empty = laspy.LasData(laspy.LasHeader(point_format=6, version="1.4"))
    empty.write(tiles / "empty.las")
    proc = lidar_sig_cli("signature", tiles, "-o", tmp_path / "s.h5", "--workers", "1")
    assert proc.returncode == 2 and "empty.las" in proc.stderr and "no points" in proc.stderr, proc.stderr
    (tiles / "empty.las").unlink()
    xyz = ls.read(SAMPLES / "epoch1.laz").xyz[:2000]
    write_las(tiles / "nocrs.las", xyz)  # the same points, without the CRS of the others
    proc = lidar_sig_cli("signature", tiles, "-o", tmp_path / "s.h5", "--workers", "1")
    assert proc.returncode == 2 and "nocrs.las" in proc.stderr and "CRS" in proc.stderr, proc.stderr
    assert not (tmp_path / "s.h5").exists()


def test_compare_with_a_tiling_option_processes_a_file_in_tiles(tmp_path):
    proc = lidar_sig_cli("compare", SAMPLES / "epoch1.laz", SAMPLES / "epoch1.laz", "--tile-size", "30",
                         "--workers", "1")
    assert proc.returncode == 0, proc.stderr
    assert "set of tiles" in proc.stdout, proc.stdout
    assert " 0.0000 " in proc.stdout and "s_SSIM        1.0000" in proc.stdout


def test_a_signal_during_a_streamed_write_stops_it_at_the_next_chunk(tmp_path):
    import os
    import signal

    from lidar_sig.base.errors import Interrupted
    from lidar_sig.io.las import write_las_chunks

    src = SAMPLES / "epoch1.laz"
    sal = ls.Pipeline(progress=False).saliency(ls.read(src))[0]
    asked = []

    def chunks(a, b):
        asked.append(a)
        if len(asked) == 2:
            os.kill(os.getpid(), signal.SIGINT)  # held while the file is written
        return ls.Saliency.from_values(sal.values[a:b])

    with pytest.raises(Interrupted):
        write_las_chunks(tmp_path / "o.laz", src, chunks, scale_kind="knn", scale_values=(20, 30, 40),
                         chunk_points=5_000)
    assert len(asked) == 2  # not the 9 chunks of the file
    assert list(tmp_path.iterdir()) == []


def test_a_set_of_tiles_may_be_named_by_a_glob_pattern_or_a_virtual_point_cloud(tmp_path):
    # the tiles of a set as QGIS and PDAL list them (.vpc), or a quoted pattern, as a folder's
    import json

    from lidar_sig.tiling.sources import expand

    folder = need_data(IGN)
    vpc = tmp_path / "ign.vpc"
    vpc.write_text(json.dumps({"type": "FeatureCollection", "features": [
        {"type": "Feature", "assets": {"data": {"href": str(p), "roles": ["data"]}}} for p in IGN_FILES]}))
    assert expand([folder / "*.laz"]) == expand([folder]) == expand([vpc])
    with pytest.raises(ls.LidarSigError, match="matches no point-cloud file"):
        expand([folder / "*.las"])


def test_a_result_of_another_run_is_replaced_quietly_and_a_damaged_one_is_noted(tmp_path):
    # a tile of an earlier version wrote other files beside its result (no sample points): a
    # resumed run recomputes it as another run's, not as a damaged file
    from lidar_sig.tiling.work import damaged, load_done, save_whole

    path, extra = tmp_path / "tile_0_0.npz", tmp_path / "tile_0_0.sample.npy"
    save_whole(path, key=np.array("earlier method"))
    assert load_done(path, "this method", tmp_path, extra=(extra,)) is None
    assert not path.exists() and damaged(tmp_path) == []
    save_whole(path, key=np.array("this method"))  # this run's result, a file it wrote missing
    assert load_done(path, "this method", tmp_path, extra=(extra,)) is None
    assert not path.exists() and damaged(tmp_path) == [str(path)]
    save_whole(path, key=np.array("this method"))
    save_whole(extra, np.zeros(3))
    assert str(load_done(path, "this method", tmp_path, extra=(extra,))["key"]) == "this method"


def test_a_resumed_staging_says_why_it_stages_a_file_again(tmp_path, monkeypatch):
    # a run interrupted while staging leaves later parts finished and the first (which also
    # hashes the file) not: the file is staged again whole, and that was said as "edited since"
    from lidar_sig.tiling import sources as staging
    from lidar_sig.tiling._set_run import SetRun
    from lidar_sig.tiling.backends import InProcess
    from lidar_sig.tiling.run_set import _stage

    monkeypatch.setattr(staging, "PART_POINTS", 12_000)  # the sample's 41,507 points in 4 parts
    monkeypatch.setattr(staging, "CHUNK_POINTS", 5_000)
    path = tmp_path / "epoch1.laz"
    shutil.copy(SAMPLES / "epoch1.laz", path)
    (source,) = staging.scan([path])
    cells = staging.Cells(tuple(float(v) for v in source.lo[:2]), 10.0)
    parts = source.parts(1)
    assert len(parts) == 4
    work = tmp_path / "work"

    def resumed():
        run = SetRun([source])
        records = _stage(work, [source], [source], cells, run, InProcess(), True, None, False)
        return run, records

    for part in (1, 2):
        staging.stage_part(work, source, part, *parts[part], cells)
    run, records = resumed()
    assert run.restaged == ["epoch1.laz (its first part unfinished: an interrupted staging)"]
    assert run.reused_parts == 0 and len(records) == 4
    run, _ = resumed()  # now whole: every part reused, nothing said
    assert run.restaged == [] and run.reused_parts == 4
    other = tmp_path / "other.laz"  # another file where this one was in the set's list
    shutil.copy(path, other)
    (moved,) = staging.scan([other])
    run = SetRun([moved])
    _stage(work, [moved], [moved], cells, run, InProcess(), True, None, False)
    assert run.restaged == ["other.laz (another file in its place: the set's files changed)"]
