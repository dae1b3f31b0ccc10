"""HDF5 signature archives (SPEC 8): exact round trip, readable by h5dump, clear errors."""
import json
import shutil
import subprocess

import h5py
import numpy as np
import pytest

import lidar_sig as ls
from command_line import run, run_process
from conftest import IGN, NOISY, SAMPLES, airborne_like, need_data, noisy_las

DOCUMENTED = ["/signature/counts", "/signature/sg", "/signature/sas", "/signature/mask",
              "/signature/triangle", "/signature/egeom_histogram", "/signature/saliency_histograms",
              "/signature/classes/names", "/signature/classes/colors", "/signature/classes/codes",
              "/signature/classes/code_offsets", "/points/cl", "/points/cs", "/points/cp",
              "/points/egeom", "/points/geom_class", "/points/optimal_scale", "/points/labels"]


@pytest.fixture(scope="module")
def optimal_result():
    return ls.Pipeline(strategy="optimal", classes="paper").run(
        need_data(IGN / "test_data_77060_627760_LA93_IGN69.laz"))


def test_archive_round_trip_compares_exactly(optimal_result, tmp_path):
    path = tmp_path / "sig.h5"
    optimal_result.write(path)
    loaded = ls.load_signature(path)
    out = ls.compare(optimal_result.signature, loaded)
    # exactly: the archive stores the signature's counts, the same numbers come back
    assert out["ssim"] == 1.0
    assert all(out[k] == 0.0 for k in out if k != "ssim")
    assert np.array_equal(loaded.counts, optimal_result.signature.counts)
    assert loaded.classes == optimal_result.signature.classes
    with h5py.File(path) as f:
        assert f.attrs["descriptor"] == "c3dcm" and f.attrs["strategy"] == "optimal"
        src = json.loads(f.attrs["sources"])[0]
        assert src["path"].endswith("test_data_77060_627760_LA93_IGN69.laz") and len(src["sha256"]) == 64
        np.testing.assert_array_equal(f["points/geom_class"][()], optimal_result.saliency.geom_class)
        for name in DOCUMENTED:
            assert "description" in f[name].attrs, name


def test_archive_without_points_is_smaller(optimal_result, tmp_path):
    full, small = tmp_path / "full.h5", tmp_path / "small.h5"
    optimal_result.write(full)
    optimal_result.write(small, points=False)
    with h5py.File(small) as f:
        assert "points" not in f
    assert small.stat().st_size < full.stat().st_size
    assert ls.compare(ls.load_signature(small), optimal_result.signature)["ssim"] == 1.0


@pytest.mark.skipif(shutil.which("h5dump") is None, reason="h5dump not installed (Debian package hdf5-tools)")
def test_h5dump_header_lists_documented_datasets(optimal_result, tmp_path):
    path = tmp_path / "sig.h5"
    optimal_result.write(path)
    header = subprocess.run(["h5dump", "-H", str(path)], capture_output=True, text=True, check=True).stdout
    for name in DOCUMENTED:
        assert f'DATASET "{name.rsplit("/", 1)[1]}"' in header, name
    assert 'GROUP "signature"' in header and 'GROUP "points"' in header


def test_cli_signature_archive_then_compare_and_info(tmp_path):
    # real processes: one end-to-end run of the info command, and an archive read by another process
    arc, png = tmp_path / "e1.h5", tmp_path / "e1.png"
    made = run_process("signature", SAMPLES / "epoch1.laz", "-o", arc, "--png", png, "-q")
    assert made.returncode == 0, made.stderr
    assert png.read_bytes()[:4] == b"\x89PNG"
    mixed = json.loads(run_process("compare", arc, SAMPLES / "epoch1.laz", "--json").stdout)
    # exactly: the same cloud and the same computation on one machine give the same signature
    assert mixed["ssim"] == 1.0 and mixed["emd_img"] == 0.0 and mixed["fv"] == 0.0
    info = run_process("info", arc)
    assert info.returncode == 0 and "signature archive" in info.stdout and "sha256" in info.stdout


@pytest.mark.parametrize("case", ["corrupt", "foreign", "truncated"])
def test_bad_archives_exit_2_with_one_line(tmp_path, case):
    path = tmp_path / f"{case}.h5"
    if case == "corrupt":
        path.write_bytes(b"\x89HDF\r\n\x1a\n" + b"\x00garbage" * 100)
    elif case == "foreign":
        with h5py.File(path, "w") as f:
            f["data"] = np.arange(10)
    else:
        good = tmp_path / "good.h5"
        ls.Pipeline(scales=ls.knn(10)).run(SAMPLES / "epoch1.laz").write(good)
        path.write_bytes(good.read_bytes()[:4000])
    for args in (("compare", path, SAMPLES / "epoch1.laz"), ("info", path)):
        proc = run(*args)
        assert proc.returncode == 2, proc.stderr
        lines = proc.stderr.strip().splitlines()
        assert len(lines) == 1 and path.name in lines[0] and "Traceback" not in proc.stderr


def test_compare_refuses_archive_with_another_class_table(tmp_path):
    arc = tmp_path / "asprs.h5"
    ls.Pipeline(scales=ls.knn(10, 20)).run(SAMPLES / "epoch1.laz").write(arc)
    proc = run("compare", arc, SAMPLES / "epoch2.laz", "--classes", "paper", "--k", "10,20")
    assert proc.returncode == 2
    assert "class table 'asprs'" in proc.stderr and "--classes" in proc.stderr
    assert "Traceback" not in proc.stderr


def test_k_scales_read_back_as_whole_numbers(tmp_path):
    # k-nearest scales are neighbour counts: an archive gives them as the cloud does, in JSON too
    cloud = ls.read(SAMPLES / "epoch1.laz")
    result = ls.Pipeline(scales=ls.knn(10, 20), progress=False).run(cloud)
    path = tmp_path / "e1.h5"
    result.write(path, points=False)
    loaded = ls.load_signature(path)
    assert loaded.metadata["resolved_scales"] == [10, 20]
    assert all(type(v) is int for v in loaded.metadata["resolved_scales"])
    facts = ls.compare_sources(path, cloud).to_dict()  # the cloud is computed the archive's way
    assert json.dumps(facts["a"]["scales"]) == json.dumps(facts["b"]["scales"]) == "[10, 20]"
    with h5py.File(path, "r+") as f:  # as archives made before recorded them: floats
        f.attrs["resolved_scales"] = np.array([10.0, 20.0])
    assert json.dumps(ls.load_signature(path).metadata["resolved_scales"]) == "[10, 20]"


def test_archive_records_the_points_left_out_and_the_noise_codes(tmp_path):
    noisy_las(tmp_path / "noisy.laz")
    cloud = ls.read(tmp_path / "noisy.laz")
    result = ls.Pipeline(progress=False).run(cloud)
    path = tmp_path / "noisy.h5"
    result.write(path)
    loaded = ls.load_signature(path)
    assert loaded.metadata["n_excluded"] == sum(NOISY.values()) and loaded.metadata["keep_noise"] is False
    assert loaded.classes == ls.ASPRS and loaded.classes.noise == (7, 18)
    assert "withheld or noise points left out" in "\n".join(ls.io.archive_summary(path))
    # a cloud compared with the archive is computed the archive's way: noise left out
    same = ls.compare_sources(path, cloud)
    assert same.metrics["ssim"] == 1.0 and same.metrics["kl"] == 0.0 and same.b.summary()["excluded"] == sum(NOISY.values())
    # both sides count the cloud's points alike (the archive said those of its signature only)
    assert same.a.summary()["points"] == same.b.summary()["points"] == len(cloud)
    assert loaded.metadata["n_points"] == result.metadata["n_points"] == len(cloud)
    with h5py.File(path, "r+") as f:  # as archives made before noise codes were recorded
        del f["signature/classes/noise_codes"]
    assert ls.load_signature(path).classes == ls.ASPRS
    # an archive made before keep_noise was recorded used every point: a cloud compared with it
    # is computed so (it was computed with the noise left out: L1 0.02, s_SSIM 0.88 against itself)
    old = tmp_path / "old.h5"
    ls.Pipeline(progress=False, keep_noise=True).run(cloud).write(old)
    with h5py.File(old, "r+") as f:
        method = json.loads(f.attrs["method"])
        del method["keep_noise"], f["signature/classes/noise_codes"]
        f.attrs["method"] = json.dumps(method)
    assert ls.load_signature(old).metadata["keep_noise"] is True
    same = ls.compare_sources(old, cloud)
    assert same.metrics["ssim"] == 1.0 and same.metrics["kl"] == 0.0 and same.b.summary()["excluded"] == 0


def test_archive_of_one_withheld_point_says_so_in_the_singular(tmp_path):
    xyz, labels = airborne_like(500, seed=3)
    withheld = np.zeros(len(xyz), bool)
    withheld[7] = True
    path = tmp_path / "one.h5"
    ls.Pipeline(scales=ls.knn(10), progress=False).run(ls.PointCloud(xyz, labels, withheld=withheld)).write(path)
    text = "\n".join(ls.io.archive_summary(path))
    assert "1 withheld or noise point left out" in text, text
    assert ls.load_signature(path).metadata["n_points"] == len(xyz)
