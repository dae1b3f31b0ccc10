"""The command line as a user runs it: exit codes, one-line errors. A real process runs the
saliency, signature, compare and plugins commands once each (the last through the installed
`lidar-sig` script); the rest run in this process (tests/command_line.py)."""
import json
import shutil
import subprocess

import laspy
import numpy as np
import pytest

from command_line import run, run_process
from conftest import IGN, SAMPLES, need_data

WEST = IGN / "test_data_77050_627755_LA93_IGN69.laz"
EAST = IGN / "test_data_77060_627755_LA93_IGN69.laz"
SMALL = IGN / "test_data_77060_627760_LA93_IGN69.laz"


def assert_user_error(proc, name):
    assert proc.returncode == 2, proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1, proc.stderr
    assert "Traceback" not in proc.stderr
    assert name in lines[0]


def assert_nothing_written(folder, output):
    assert not output.exists()
    assert not [p for p in folder.iterdir() if p.name.startswith(".") and p.suffix == ".tmp"]


def test_compare_real_ign_columns_prints_every_metric():
    need_data(WEST), need_data(EAST)
    proc = run_process("compare", WEST, EAST, "--json")
    assert proc.returncode == 0, proc.stderr
    out = json.loads(proc.stdout)
    for key in ("bhattacharyya", "ssim", "emd_info", "emd_img", "fv", "kl", "l1"):
        assert isinstance(out[key], float), key
    assert 0 <= out["bhattacharyya"] <= 1 and -1 <= out["ssim"] <= 1
    assert out["bhattacharyya"] > 0 and out["ssim"] < 1 and out["kl"] > 0 and out["l1"] > 0
    table = run("compare", WEST, EAST)
    assert table.returncode == 0
    for name in ("d_BD-Img", "s_SSIM", "d_EMD-Info", "d_EMD-Img", "delta_FV", "delta_KL", "L1"):
        assert name in table.stdout


def test_compare_file_with_itself_gives_zero_distances():
    need_data(SMALL)
    out = json.loads(run("compare", SMALL, SMALL, "--json", "--strategy", "optimal").stdout)
    # exactly: one file computed twice the same way on one machine gives the same signature,
    # on any CPU, and a signature's distance to itself is 0
    assert out["ssim"] == 1.0
    assert out["bhattacharyya"] == out["emd_info"] == out["emd_img"] == out["fv"] == 0.0
    assert out["kl"] == out["l1"] == 0.0


def test_compare_defaults_use_the_same_k_and_warn_only_for_normalized_radii():
    e1, e2 = SAMPLES / "epoch1.laz", SAMPLES / "epoch2.laz"
    proc = run("compare", e1, e2, "--json")
    assert proc.returncode == 0, proc.stderr
    out = json.loads(proc.stdout)
    assert out["a"]["scales"] == out["b"]["scales"] == [20, 30, 40] and out["warnings"] == []
    assert proc.stderr == ""
    # the paper's normalized radii follow each cloud's bounding box: the epochs differ in extent
    paper = run("compare", e1, e2, "--json", "--units", "normalized", "--radii", "0.009,0.010,0.011")
    out = json.loads(paper.stdout)
    assert out["a"]["scales"] != out["b"]["scales"]
    assert any("normalized radii" in w for w in out["warnings"]) and "normalized radii" in paper.stderr


def test_saliency_writes_laz_and_refuses_existing_output(tmp_path):
    src = need_data(SMALL)
    out = tmp_path / "sal.laz"
    proc = run_process("saliency", src, "-o", out, "--strategy", "optimal")
    assert proc.returncode == 0, proc.stderr
    assert "OptimalScale" in laspy.read(out).point_format.extra_dimension_names
    before = out.read_bytes()
    again = run_process("saliency", src, "-o", out)  # the exit status of the process itself
    assert_user_error(again, str(out))
    assert "--overwrite" in again.stderr and out.read_bytes() == before
    assert run("saliency", src, "-o", out, "--overwrite", "-q").returncode == 0
    assert "OptimalScale" not in laspy.read(out).point_format.extra_dimension_names


def test_signature_writes_png(tmp_path):
    out, sg = tmp_path / "sas.png", tmp_path / "sg.png"
    proc = run_process("signature", SAMPLES / "epoch1.laz", "-o", out, "--sg", sg, "--classes", "paper")
    assert proc.returncode == 0, proc.stderr
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and sg.exists()


def _las(path, xyz):
    header = laspy.LasHeader(point_format=6, version="1.4")
    header.scales = [0.01, 0.01, 0.01]
    las = laspy.LasData(header)
    if len(xyz):
        las.x, las.y, las.z = xyz[:, 0], xyz[:, 1], xyz[:, 2]
    las.write(path)
    return path


def _bad_inputs(tmp_path):
    text = tmp_path / "text.laz"
    text.write_text("this is not a point cloud\n")
    truncated = tmp_path / "truncated.laz"
    if SMALL.exists():
        truncated.write_bytes(SMALL.read_bytes()[:150_000])
    nan = tmp_path / "nan.xyz"
    nan.write_text("0 0 0\n1 0 0\nnan 1 0\n0 1 1\n")
    return {
        "missing": (tmp_path / "missing.laz", []),
        "text named .laz": (text, []),
        "truncated": (truncated, []),
        "no points": (_las(tmp_path / "empty.laz", np.zeros((0, 3))), []),
        "fewer points than k": (_las(tmp_path / "five.laz", np.random.default_rng(0).uniform(0, 9, (5, 3))),
                                ["--strategy", "optimal"]),
        "fewer points than a neighbourhood": (_las(tmp_path / "two.las", np.array([[0, 0, 0], [1, 1, 1.0]])), []),
        "NaN coordinates": (nan, []),
    }


@pytest.mark.parametrize("case", ["missing", "text named .laz", "truncated", "no points",
                                  "fewer points than k", "fewer points than a neighbourhood",
                                  "NaN coordinates"])
@pytest.mark.parametrize("command", ["saliency", "signature", "compare"])
def test_bad_input_exits_2_with_one_line_and_no_output(tmp_path, case, command):
    if case == "truncated":
        need_data(SMALL)
    src, extra = _bad_inputs(tmp_path)[case]
    outdir = tmp_path / "out"
    outdir.mkdir()
    output = outdir / ("o.png" if command == "signature" else "o.laz")
    args = [command, src] + (["-o", output] if command != "compare" else [src]) + extra
    proc = run(*args)
    assert_user_error(proc, src.name)
    assert_nothing_written(outdir, output)


def test_bad_option_values_exit_2(tmp_path):
    src = SAMPLES / "epoch1.laz"
    for args in (["--radii", "a,b"], ["--units", "metric"], ["--descriptor", "nope"], ["--k", "1.5"]):
        proc = run("saliency", src, "-o", tmp_path / "o.laz", *args)
        assert proc.returncode == 2 and "Traceback" not in proc.stderr, args
        assert not (tmp_path / "o.laz").exists()


def test_plugins_lists_builtins():
    proc = run("plugins")
    assert proc.returncode == 0
    for name in ("c3dcm", "multiscale", "optimal"):
        assert name in proc.stdout


@pytest.mark.skipif(shutil.which("lidar-sig") is None,
                    reason="the lidar-sig script is not on PATH (pip install -e . installs it)")
def test_the_installed_lidar_sig_script_runs_the_command_line():
    proc = subprocess.run(["lidar-sig", "plugins"], capture_output=True, text=True, timeout=600,
                          stdin=subprocess.DEVNULL)
    assert proc.returncode == 0, proc.stderr
    assert "c3dcm" in proc.stdout and "multiscale" in proc.stdout
    bad = subprocess.run(["lidar-sig", "plugins", "--bogus"], capture_output=True, text=True, timeout=600,
                         stdin=subprocess.DEVNULL)
    assert_user_error(bad, "--bogus")
