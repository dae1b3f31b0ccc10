"""Point-cloud formats: PLY, PCD and text round trips on real data; bad files (SPEC 8, issue 4)."""
import subprocess
import sys

import numpy as np
import pytest

import lidar_sig as ls
from conftest import IGN, need_data
from lidar_sig.io import write_cloud

open3d = pytest.importorskip("open3d", reason="PLY/PCD need open3d: pip install -e '.[formats]'")

TILE = IGN / "test_data_77060_627760_LA93_IGN69.laz"


@pytest.fixture(scope="module")
def original():
    return ls.Pipeline().run(need_data(TILE))


@pytest.mark.parametrize("ext", [".ply", ".pcd", ".xyz", ".txt"])
def test_round_trip_keeps_coordinates_labels_and_signature(original, tmp_path, ext):
    path = tmp_path / f"tile{ext}"
    original.write(path)
    back = ls.read(path)
    np.testing.assert_array_equal(back.xyz, original.cloud.xyz)  # float64 or 17 digits: exact
    np.testing.assert_array_equal(back.labels, original.cloud.labels)
    np.testing.assert_allclose(back.attributes["Cl"], original.saliency.cl, rtol=1e-6, equal_nan=True)
    again = ls.Pipeline().run(back)
    assert np.array_equal(again.signature.counts, original.signature.counts)


def test_isprs_vaihingen_text_layout(tmp_path):
    rng = np.random.default_rng(0)
    xyz = rng.uniform(0, 20, (3000, 3)) * [1, 1, 0.2] + [497000.0, 5419000.0, 260.0]
    rows = np.column_stack([xyz, rng.integers(0, 255, 3000), np.ones(3000), np.ones(3000),
                            rng.integers(0, 9, 3000)])
    path = tmp_path / "vaihingen.pts"
    np.savetxt(path, rows, fmt=["%.2f"] * 3 + ["%d"] * 4)
    cloud = ls.read(path)
    np.testing.assert_allclose(cloud.xyz, np.round(xyz, 2))
    assert np.array_equal(cloud.labels, rows[:, 6].astype(int))
    assert set(cloud.attributes) == {"intensity", "return_number", "number_of_returns"}
    sig = ls.Pipeline(classes="isprs-vaihingen", scales=ls.knn(10, 20)).run(cloud).signature
    assert sig.classes.name == "isprs-vaihingen" and sig.class_counts[:9].sum() == 3000


def _cli(*args):
    return subprocess.run([sys.executable, "-m", "lidar_sig", *map(str, args)], capture_output=True,
                          text=True, timeout=600)


def _bad_files(tmp_path):
    ragged = tmp_path / "ragged.txt"
    ragged.write_text("0 0 0\n1 0 0\n1 1\n0 1 1\n")
    five = tmp_path / "five.txt"
    five.write_text("0 0 0 1 2\n1 0 0 1 2\n")
    empty_ply = tmp_path / "empty.ply"
    empty_ply.write_text("ply\nformat ascii 1.0\nelement vertex 0\nproperty float x\nproperty float y\n"
                         "property float z\nend_header\n")
    faces = tmp_path / "faces.ply"
    faces.write_text("ply\nformat ascii 1.0\nelement face 0\nproperty list uchar int vertex_indices\nend_header\n")
    return {"ragged": (ragged, []), "unnamed columns": (five, []),
            "columns mismatch": (five, ["--columns", "x,y,z"]),
            "ply without vertices": (empty_ply, []), "ply of faces only": (faces, [])}


@pytest.mark.parametrize("case", ["ragged", "unnamed columns", "columns mismatch", "ply without vertices",
                                  "ply of faces only"])
def test_bad_files_exit_2_one_line_nothing_written(tmp_path, case):
    src, extra = _bad_files(tmp_path)[case]
    out = tmp_path / "out" / "o.laz"
    out.parent.mkdir()
    proc = _cli("saliency", src, "-o", out, *extra)
    assert proc.returncode == 2, proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and src.name in lines[0] and "Traceback" not in proc.stderr
    assert list(out.parent.iterdir()) == []


def test_las_users_do_not_import_open3d():
    code = ("import sys, lidar_sig as ls; ls.Pipeline(scales=ls.knn(10)).run(%r); "
            "print('open3d' in sys.modules)" % str(need_data(TILE)))
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.strip() == "False"


def test_cli_user_class_table_and_info(tmp_path):
    table = tmp_path / "ign.toml"
    table.write_text('name = "ign-3"\n[[class]]\nname = "vegetation"\ncodes = [3, 4, 5]\ncolor = [20, 140, 40]\n'
                     '[[class]]\nname = "building"\ncodes = [6]\ncolor = [220, 50, 40]\n')
    out = tmp_path / "sig.h5"
    proc = _cli("signature", need_data(TILE), "-o", out, "--classes", table, "-q")
    assert proc.returncode == 0, proc.stderr
    sig = ls.load_signature(out)
    assert sig.classes.name == "ign-3" and sig.classes.class_names == ("vegetation", "building", "other")
    cloud = ls.read(TILE)
    assert sig.class_counts.sum() == len(cloud) - sig.n_undefined
    assert 0 < sig.class_counts[0] <= np.isin(cloud.labels, [3, 4, 5]).sum()
    info = _cli("info", TILE)
    assert info.returncode == 0 and "59,606 points" in info.stdout and "WktCoordinateSystemVlr" in info.stdout
