"""The memory budget (issue 18): one file whose one-block run would need more than --memory is
processed in tiles, with the one-block results, into the one output named."""
import json
import math
import os

import laspy
import numpy as np
import pytest

import lidar_sig as ls
from lidar_sig.base.errors import LidarSigError
from lidar_sig.tiling._median import sorted_median
from lidar_sig.tiling.memory import DEFAULT_MEMORY, GIB, MIB, block_bytes, budget_bytes, over_budget

from command_line import run as lidar_sig_cli
from conftest import SAMPLES

EPOCH1 = SAMPLES / "epoch1.laz"
N_EPOCH1 = 41_507
# A budget just below what the sample needs as one block, by the library's own estimate: the
# file is then processed in tiles (the tests do not depend on the estimate's constants).
SMALL = f"{math.floor((block_bytes(N_EPOCH1) - 1) / MIB)}MiB"


@pytest.fixture(scope="module")
def single():
    """The sample run as one block, by the library (the reference of every tiled run here)."""
    return ls.Pipeline(progress=False).run(EPOCH1)


def saliency_of(path):
    las = laspy.read(path)
    return np.column_stack([las["Cl"], las["Cs"], las["Cp"]]), las


@pytest.mark.parametrize("text, expected", [
    ("1GiB", GIB), ("800MiB", 800 * MIB), ("1.5GiB", 3 * GIB // 2), ("2G", 2 * GIB), ("2GB", 2 * GIB),
    ("1073741824", GIB), ("1073741824B", GIB), ("900m", 900 * MIB), (" 4 GiB ", 4 * GIB), ("2.5g", 5 * GIB // 2),
])
def test_memory_sizes_are_read_in_binary_units_a_bare_number_in_bytes(text, expected):
    assert budget_bytes(text) == expected


@pytest.mark.parametrize("value", ["500B", "1B", "2", "1", 500, np.int64(500)])
def test_a_budget_in_bytes_is_bytes_and_refused_as_too_small_naming_the_least(value):
    with pytest.raises(LidarSigError, match=r"give at least \d+MiB") as err:
        budget_bytes(value)
    assert "bytes" in str(err.value) or "1 byte" in str(err.value)


def test_numpy_integers_are_taken_as_memory_and_workers_alike():
    assert ls.Execution(memory=np.int64(GIB)).memory == GIB == ls.Execution(memory="1073741824").memory
    assert ls.Execution(workers=np.int64(1)).workers == 1


def test_a_budget_above_the_machine_s_memory_is_taken_with_a_note():
    from lidar_sig.tiling.memory import machine_bytes

    machine = machine_bytes()
    if machine is None:
        pytest.skip("this system does not tell its physical memory")
    above = 2 ** math.ceil(math.log2(machine) + 1)
    with pytest.warns(ls.LidarSigWarning, match="more than this machine's memory"):
        assert ls.Execution(memory=above).memory == above
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        ls.Execution(memory="1GiB")


def test_a_scheduler_address_is_taken_without_its_surrounding_spaces():
    assert ls.Execution(scheduler=" tcp://127.0.0.1:1 ").scheduler == "tcp://127.0.0.1:1"


@pytest.mark.parametrize("text", ["", "abc", "-1", "0", "1.5.2", "1XB", "nan", "inf", "1,5G", "G"])
def test_a_memory_size_that_is_not_one_is_refused_naming_it(text):
    with pytest.raises(LidarSigError, match="memory") as err:
        budget_bytes(text)
    assert repr(text) in str(err.value) and "1GiB" in str(err.value)


def test_a_budget_below_what_a_process_needs_names_the_least(tmp_path):
    proc = lidar_sig_cli("saliency", EPOCH1, "-o", tmp_path / "x.laz", "--memory", "100MiB")
    assert proc.returncode == 2 and len(proc.stderr.strip().splitlines()) == 1, proc.stderr
    assert "--memory 100MiB" in proc.stderr and "give at least" in proc.stderr and "Traceback" not in proc.stderr
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("value", ["lots", "-2G", "0", "1.5.2GiB"])
def test_a_bad_memory_option_is_one_line_before_any_work(tmp_path, value):
    proc = lidar_sig_cli("signature", EPOCH1, "-o", tmp_path / "s.h5", "--memory", value)
    assert proc.returncode == 2 and len(proc.stderr.strip().splitlines()) == 1, proc.stderr
    assert "--memory" in proc.stderr and repr(value) in proc.stderr and "Traceback" not in proc.stderr
    assert list(tmp_path.iterdir()) == []


def test_the_default_budget_keeps_a_million_points_and_the_sample_as_one_block(tmp_path):
    assert DEFAULT_MEMORY == GIB
    assert not over_budget(1_000_000, DEFAULT_MEMORY) and over_budget(20_000_000, DEFAULT_MEMORY)
    proc = lidar_sig_cli("saliency", EPOCH1, "-o", tmp_path / "x.laz")
    assert proc.returncode == 0, proc.stderr
    assert "memory budget" not in proc.stdout and "tiles" not in proc.stdout
    assert f"{N_EPOCH1:,} points, c3dcm multiscale" in proc.stdout


def test_a_file_over_the_budget_is_written_whole_from_tiles_with_the_one_block_values(tmp_path, single):
    out = tmp_path / "out.laz"
    proc = lidar_sig_cli("saliency", EPOCH1, "-o", out, "--memory", SMALL, "-v")
    assert proc.returncode == 0, proc.stderr
    assert f"{N_EPOCH1:,} points exceed the {SMALL[:-3]} MiB memory budget as one block: processed in" in proc.stdout
    for stage in ("staging", "area-weight cap", "tiles", "writing out.laz"):  # where the time goes
        assert f"lidar-sig: {stage}: " in proc.stderr, stage
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.laz"]  # the work folder is gone
    got, las = saliency_of(out)
    source = laspy.read(EPOCH1)
    assert len(las.points) == N_EPOCH1 and np.array_equal(las.x, source.x) and np.array_equal(las.y, source.y)
    assert np.array_equal(las.classification, source.classification)
    # float32 of values equal to 1e-12 (tied neighbours summed in another order: test_tiling)
    expected = single.saliency.values.astype(np.float32)
    assert np.array_equal(np.isnan(got), np.isnan(expected))
    assert np.allclose(got, expected, rtol=0, atol=1e-6, equal_nan=True)


def test_a_file_over_the_budget_runs_on_a_worker_per_core_and_gives_the_same_file(tmp_path):
    one = tmp_path / "one.laz"
    two = tmp_path / "two.laz"
    proc = lidar_sig_cli("saliency", EPOCH1, "-o", one, "--memory", SMALL, "--workers", "1")
    assert proc.returncode == 0 and "1 process:" in proc.stdout, proc.stderr
    proc = lidar_sig_cli("saliency", EPOCH1, "-o", two, "--memory", SMALL)  # default: a worker per core
    assert proc.returncode == 0, proc.stderr
    cores = len(os.sched_getaffinity(0))  # the cores this process may use
    assert (f"{cores} local processes" if cores > 1 else "1 process:") in proc.stdout
    # the same tiles on other processes: the same arithmetic, so the same bytes
    assert np.array_equal(saliency_of(one)[0], saliency_of(two)[0], equal_nan=True)


@pytest.mark.parametrize("name", ["out.ply", "out.xyz"])
def test_a_non_las_output_over_the_budget_is_refused_in_one_line(tmp_path, name):
    proc = lidar_sig_cli("saliency", EPOCH1, "-o", tmp_path / name, "--memory", SMALL)
    assert proc.returncode == 2 and len(proc.stderr.strip().splitlines()) == 1, proc.stderr
    assert name in proc.stderr and "LAS/LAZ" in proc.stderr and "--memory" in proc.stderr
    assert "Traceback" not in proc.stderr and list(tmp_path.iterdir()) == []


def test_python_runs_a_file_over_the_budget_in_tiles_and_writes_the_commands_file(tmp_path, single):
    # the notebook's line decides as the command does: the same file, from tiles kept on disk
    cli = tmp_path / "cli.laz"
    assert lidar_sig_cli("saliency", EPOCH1, "-o", cli, "--memory", SMALL, "-q").returncode == 0
    work = tmp_path / "work"
    work.mkdir()
    result = ls.Pipeline(progress=False).run(EPOCH1, execution=ls.Execution(memory=SMALL, work_dir=work))
    assert result.tiled and "in tiles" in repr(result) and len(repr(result)) <= 300
    assert result.work.parent == work and result.work.is_dir()  # the per-point values wait there, not in memory
    other = ls.Pipeline(progress=False).run(EPOCH1, execution=ls.Execution(memory=SMALL, work_dir=work))
    assert other.work.parent == work and other.work != result.work  # two results never share a folder
    other.close()
    result.write(tmp_path / "py.laz")
    got_cli, _ = saliency_of(cli)
    got_py, _ = saliency_of(tmp_path / "py.laz")
    assert np.array_equal(got_cli, got_py, equal_nan=True)
    for key in ("counts", "egeom_counts", "class_totals"):
        assert np.array_equal(getattr(result.signature, key), getattr(single.signature, key)), key
    assert np.allclose(result.saliency.values, single.saliency.values, rtol=0, atol=1e-12, equal_nan=True)
    result.write(tmp_path / "s.h5")  # the signature and the tiling, no per-point datasets
    assert ls.load_signature(tmp_path / "s.h5").n_points == single.signature.n_points
    with pytest.raises(LidarSigError, match="points=True"):
        result.write(tmp_path / "p.h5", points=True)
    with pytest.raises(LidarSigError, match="LAS/LAZ only.*memory"):
        result.write(tmp_path / "out.ply")
    result.close()
    assert list(work.iterdir()) == []
    with pytest.raises(LidarSigError, match="closed"):
        result.write(tmp_path / "again.laz")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["cli.laz", "py.laz", "s.h5", "work"]


def test_a_result_in_tiles_removes_its_temporary_work_folder_when_collected(tmp_path, monkeypatch):
    import gc
    import tempfile

    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))
    result = ls.Pipeline(progress=False).run(EPOCH1, execution=ls.Execution(memory=SMALL))
    work = result.work
    assert work.parent == tmp_path and work.is_dir()
    del result
    gc.collect()
    assert not work.exists()


def test_the_signature_of_a_file_over_the_budget_is_the_one_block_signature(tmp_path, single):
    out = tmp_path / "s.h5"
    proc = lidar_sig_cli("signature", EPOCH1, "-o", out, "--memory", SMALL)
    assert proc.returncode == 0, proc.stderr
    assert "memory budget as one block: processed in" in proc.stdout
    assert sorted(p.name for p in tmp_path.iterdir()) == ["s.h5"]
    sig = ls.load_signature(out)
    for key in ("counts", "egeom_counts", "class_totals"):  # integer counts: exactly equal
        assert np.array_equal(getattr(sig, key), getattr(single.signature, key)), key
    proc = lidar_sig_cli("signature", EPOCH1, "--report", tmp_path / "r.html", "--memory", SMALL)
    assert proc.returncode == 2 and "--report" in proc.stderr and "--memory" in proc.stderr, proc.stderr
    assert not (tmp_path / "r.html").exists()


def test_compare_computes_an_input_over_the_budget_in_tiles_with_the_same_metrics(tmp_path):
    # epoch2 is labelled, the copy of epoch1 is not: geometry only, as for two clouds
    unlabelled = tmp_path / "unlabelled.laz"
    las = laspy.read(EPOCH1)
    las.classification[:] = 0
    las.write(unlabelled)
    for a, b in ((EPOCH1, SAMPLES / "epoch2.laz"), (unlabelled, SAMPLES / "epoch2.laz"),
                 (SAMPLES / "epoch2.laz", unlabelled)):
        whole = lidar_sig_cli("compare", a, b, "--json")
        tiled = lidar_sig_cli("compare", a, b, "--json", "--memory", SMALL)
        assert whole.returncode == 0 and tiled.returncode == 0, tiled.stderr
        assert "memory budget as one block: processed in" in tiled.stderr
        w, t = json.loads(whole.stdout), json.loads(tiled.stdout)
        for key in ("bhattacharyya", "ssim", "emd_info", "emd_img", "fv", "kl", "l1"):
            if w[key] is None:  # a metric the inputs cannot give (kl, l1 without labels): none either way
                assert t[key] is None, (a.name, b.name, key)
            else:
                assert t[key] == pytest.approx(w[key], rel=1e-12, abs=1e-12), (a.name, b.name, key)
        assert "set of tiles" in (t["a"]["kind"], t["b"]["kind"]) and t["warnings"] == w["warnings"]


def test_python_compare_of_a_file_over_the_budget_with_an_archive_runs_it_in_tiles_in_a_folder_of_its_own(tmp_path):
    # the archive's method is read first; it decides that the LAS file runs in tiles, in a new
    # folder inside the given work folder (which holds the user's file and keeps it)
    archive = tmp_path / "epoch2.h5"
    ls.Pipeline(progress=False).run(SAMPLES / "epoch2.laz").write(archive)
    work = tmp_path / "work"
    work.mkdir()
    (work / "mine.txt").write_text("the user's")
    whole = ls.compare(EPOCH1, archive)
    with pytest.warns(ls.LidarSigWarning, match="memory budget as one block: processed in"):
        tiled = ls.compare(EPOCH1, archive, execution=ls.Execution(memory=SMALL, work_dir=work))
    assert sorted(p.name for p in work.iterdir()) == ["mine.txt"]
    for key, value in whole.metrics.items():
        assert tiled.metrics[key] == pytest.approx(value, rel=1e-12, abs=1e-12), key


def test_a_tiled_run_that_fails_or_is_interrupted_leaves_nothing(tmp_path, monkeypatch):
    from lidar_sig.tiling import run_set as tiling_run

    def fails(plan, ij):
        raise RuntimeError("a tile failed")

    # one core: the tiles run in the command's own process, where the failing task is patched in
    monkeypatch.setattr("lidar_sig.tiling.backends.cores", lambda: 1)
    monkeypatch.setattr(tiling_run, "tile_task", fails)
    proc = lidar_sig_cli("saliency", EPOCH1, "-o", tmp_path / "out.laz", "--memory", SMALL)
    assert proc.returncode == 2 and "could not be processed in tiles" in proc.stderr, proc.stderr
    assert list(tmp_path.iterdir()) == []

    def interrupted(plan, ij):
        raise KeyboardInterrupt

    monkeypatch.setattr(tiling_run, "tile_task", interrupted)
    proc = lidar_sig_cli("signature", EPOCH1, "-o", tmp_path / "s.h5", "--memory", SMALL)
    assert proc.returncode == 130 and "interrupted" in proc.stderr, proc.stderr
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("sizes", [[7], [3, 4], [1000, 1, 2000, 5], [0, 10, 11]])
def test_the_median_of_sorted_files_is_numpys(tmp_path, sizes):
    rng = np.random.default_rng(sum(sizes))
    # half the values from two, so that equal values span files and the middle
    arrays = [np.sort(np.where(rng.random(n) < 0.5, rng.choice([0.5, 1.0], n), rng.uniform(0.0, 3.0, n)))
              for n in sizes]
    paths = []
    for i, a in enumerate(arrays):
        paths.append(tmp_path / f"{i}.npy")
        np.save(paths[-1], a)
    # the same value, not a close one: the set's cap must be the single block's
    assert sorted_median(paths) == float(np.median(np.concatenate(arrays)))


def test_a_change_map_in_one_block_counts_the_base_of_its_process():
    # issue 46: the one-block rule of `changes` left out the memory a process holds before any
    # point, so that a pair within the budget by its points alone ran as one block above it
    from lidar_sig.change_map._in_units import ONE_BLOCK_BYTES_PER_POINT, in_units
    from lidar_sig.tiling.memory import BASE_BYTES, header_points

    epochs = [str(EPOCH1), str(SAMPLES / "epoch2.laz")]
    n = sum(header_points(p) for p in epochs)
    pipe = ls.Pipeline(progress=False)
    points_alone = n * ONE_BLOCK_BYTES_PER_POINT
    below = ls.Execution(memory=max(BASE_BYTES + points_alone - 1, budget_bytes("366MiB")))
    assert points_alone < below.memory < BASE_BYTES + points_alone
    assert in_units(epochs, below, pipe) is not None  # in work units, within the budget
    assert in_units(epochs, ls.Execution(memory=BASE_BYTES + points_alone), pipe) is None  # one block fits
