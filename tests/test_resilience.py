"""`lidar-sig resilience` and lidar_sig.resilience (lidar_sig.jobs.resilience): metrics of random subsamples (SPEC 7)."""
import json

import numpy as np

import lidar_sig as ls
from command_line import run, run_process
from conftest import SAMPLES, airborne_like
from lidar_sig.jobs.resilience import resilience


def test_full_fraction_is_identical_and_distances_grow_as_points_go():
    xyz, labels = airborne_like(6000, seed=21)
    res = resilience(ls.PointCloud(xyz, labels), fractions=(1.0, 0.8, 0.4), repeats=2, seed=3)
    assert res.points == (6000, 4800, 2400)
    mean = {k: res.summary(k)[0] for k in res.values}
    assert mean["ssim"][0] == 1.0 and all(mean[k][0] == 0.0 for k in mean if k != "ssim")
    for key in ("bhattacharyya", "emd_info", "fv"):
        assert 0 < mean[key][1] < mean[key][2], key
    assert mean["ssim"][2] < mean["ssim"][1] < 1.0
    again = resilience(ls.PointCloud(xyz, labels), fractions=(1.0, 0.8, 0.4), repeats=2, seed=3)
    assert all(np.array_equal(res.values[k], again.values[k]) for k in res.values)  # seeded


def test_resilience_command_prints_json_and_draws_a_plot(tmp_path):
    plot = tmp_path / "res.png"
    proc = run_process("resilience", SAMPLES / "epoch2.laz", "--fractions", "1,0.6", "--repeats", "2", "--json",
                       "--plot", plot, "-q")  # the command's end-to-end run in a real process
    assert proc.returncode == 0, proc.stderr
    out = json.loads(proc.stdout)
    assert out["fractions"] == [1.0, 0.6] and out["repeats"] == 2 and out["render"] == "smooth"
    assert out["metrics"]["fv"]["mean"][0] == 0.0 < out["metrics"]["fv"]["mean"][1]
    assert out["method"]["scale_values"] == [20, 30, 40]
    assert plot.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    table = run("resilience", SAMPLES / "epoch2.laz", "--fractions", "0.9", "--repeats", "1", "--render", "points")
    assert table.returncode == 0 and "d_BD-Img" in table.stdout and "points rendering" in table.stdout


def test_resilience_refuses_bad_fractions_and_existing_plot_before_work(tmp_path):
    for bad in ("0", "1.5", "", "a"):
        proc = run("resilience", SAMPLES / "epoch2.laz", "--fractions", bad)
        assert proc.returncode == 2 and len(proc.stderr.strip().splitlines()) == 1, (bad, proc.stderr)
    proc = run("resilience", SAMPLES / "epoch2.laz", "--seed", "-1")
    assert proc.returncode == 2 and "--seed" in proc.stderr and len(proc.stderr.strip().splitlines()) == 1
    proc = run("resilience", SAMPLES / "epoch2.laz", "--fractions", "1e-6")
    assert proc.returncode == 2 and "epoch2.laz" in proc.stderr and "fraction 1e-06 keeps 0" in proc.stderr
    plot = tmp_path / "there.png"
    plot.write_bytes(b"keep")
    proc = run("resilience", SAMPLES / "epoch2.laz", "--plot", plot)
    assert proc.returncode == 2 and "--overwrite" in proc.stderr and plot.read_bytes() == b"keep"
