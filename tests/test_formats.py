"""Point-cloud formats: PLY, PCD and text round trips on real data; bad files (SPEC 8, issue 4);
every attribute kept, names CloudCompare and Open3D read (issue 10)."""
import subprocess
import sys

import laspy
import numpy as np
import pytest

import lidar_sig as ls
from command_line import run
from conftest import IGN, need_data
from lidar_sig.base.errors import LidarSigWarning

open3d = pytest.importorskip("open3d", reason="PLY/PCD need open3d: pip install -e '.[formats]'")

TILE = IGN / "test_data_77060_627760_LA93_IGN69.laz"


@pytest.fixture(scope="module")
def original(default_run):
    return default_run(TILE)


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
    proc = run("saliency", src, "-o", out, *extra)
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
    proc = run("signature", need_data(TILE), "-o", out, "--classes", table, "-q")
    assert proc.returncode == 0, proc.stderr
    sig = ls.load_signature(out)
    assert sig.classes.name == "ign-3" and sig.classes.class_names == ("vegetation", "building", "other")
    cloud = ls.read(TILE)
    assert sig.class_counts.sum() == len(cloud) - sig.n_undefined
    assert 0 < sig.class_counts[0] <= np.isin(cloud.labels, [3, 4, 5]).sum()
    info = run("info", TILE)
    assert info.returncode == 0 and "59,606 points" in info.stdout and "WktCoordinateSystemVlr" in info.stdout


@pytest.fixture(scope="module", params=[255, 65535], ids=["8-bit colours", "16-bit colours"])
def coloured(request, tmp_path_factory):
    """The IGN tile (whose RGB is all zero) with random colours up to the given maximum, and a
    Multiscale result on it."""
    las = laspy.read(need_data(TILE))
    rng = np.random.default_rng(request.param)
    for name in ("red", "green", "blue"):
        las[name] = rng.integers(0, request.param, len(las.points), endpoint=True)
    path = tmp_path_factory.mktemp("coloured") / "tile.laz"
    las.write(path)
    return las, ls.Pipeline(scales=ls.knn(10)).run(path)


def _ply_header(path):
    with open(path, "rb") as fh:
        return fh.read(4096).split(b"end_header")[0].decode().splitlines()


@pytest.mark.parametrize("ext", [".ply", ".pcd", ".csv", ".xyz"])
def test_outputs_keep_every_las_dimension_rgb_and_intensity(coloured, tmp_path, ext):
    las, result = coloured
    path = tmp_path / f"o{ext}"
    result.write(path)
    back = ls.read(path)
    np.testing.assert_array_equal(back.xyz, result.cloud.xyz)
    np.testing.assert_array_equal(back.labels, np.asarray(las.classification))
    rgb = np.column_stack([np.asarray(las.red), np.asarray(las.green), np.asarray(las.blue)])
    if "colors" in back.attributes:  # PLY, and PCD's packed 8-bit colour
        np.testing.assert_array_equal(back.attributes["colors"], rgb)
    else:
        np.testing.assert_array_equal(np.column_stack([back.attributes[c] for c in ("red", "green", "blue")]), rgb)
    for name in las.point_format.dimension_names:
        if name not in ("X", "Y", "Z", "classification", "red", "green", "blue"):
            np.testing.assert_array_equal(back.attributes[name], np.asarray(las[name]), err_msg=name)
    # float32 in binary files; 9 significant digits in text, which give back the same float32
    np.testing.assert_array_equal(back.attributes["Cl"].astype(np.float32), result.saliency.cl.astype(np.float32))
    assert set(back.previous_outputs) == {"Cl", "Cs", "Cp", "Egeom", "GeomClass"}


def test_ply_names_follow_cloudcompare_and_open3d_reads_every_attribute(coloured, tmp_path):
    las, result = coloured
    path = tmp_path / "o.ply"
    result.write(path)
    props = [line.split()[-1] for line in _ply_header(path) if line.startswith("property")]
    assert props[:3] == ["x", "y", "z"]
    assert {"red", "green", "blue", "scalar_intensity", "scalar_gps_time", "scalar_label", "scalar_Cl",
            "scalar_GeomClass"} <= set(props)
    assert all(p in ("red", "green", "blue") or p.startswith("scalar_") for p in props[3:])
    pc = open3d.t.io.read_point_cloud(str(path))
    expected = {"positions", "colors"} | {p for p in props if p.startswith("scalar_")}
    assert set(pc.point) == expected
    np.testing.assert_array_equal(pc.point["scalar_intensity"].numpy()[:, 0], np.asarray(las.intensity))
    np.testing.assert_array_equal(pc.point["scalar_Egeom"].numpy()[:, 0], result.saliency.egeom.astype(np.float32))
    np.testing.assert_array_equal(pc.point.positions.numpy(), result.cloud.xyz)


def test_text_header_is_cloudcompares(coloured, tmp_path):
    _, result = coloured
    path = tmp_path / "o.txt"
    result.write(path)
    first = path.read_text().splitlines()[0]
    assert first.startswith("//X,Y,Z,")
    names = first[2:].split(",")[3:]
    assert {"red", "green", "blue", "scalar_intensity", "scalar_label", "scalar_Cl", "scalar_Cp"} <= set(names)
    assert all(n in ("red", "green", "blue") or n.startswith("scalar_") for n in names)


def test_pcd_fields_follow_pcl(coloured, tmp_path):
    las, result = coloured
    path = tmp_path / "o.pcd"
    result.write(path)
    with open(path, "rb") as fh:
        fields = next(line for line in fh if line.startswith(b"FIELDS")).decode().split()[1:]
    assert fields[:3] == ["x", "y", "z"] and "label" in fields and "Cl" in fields
    if np.asarray(las.red).max() <= 255:
        assert "rgb" in fields and "red" not in fields
    else:  # PCL's rgb is 8-bit: 16-bit colours stay whole as fields of their own
        assert {"red", "green", "blue"} <= set(fields) and "rgb" not in fields
    pc = open3d.t.io.read_point_cloud(str(path))
    assert len(pc.point.positions) == len(result.cloud)


def test_foreign_attribute_named_like_ours_is_kept_in_ply(tmp_path):
    """A PLY of someone else with a 'Cl' property: kept, ours written as lidar_sig_Cl; a re-run on
    our own output replaces ours (known by the header comment) and keeps theirs."""
    cloud = ls.read(need_data(TILE))
    chlorophyll = np.linspace(0.0, 9.0, len(cloud))
    user = ls.PointCloud(cloud.xyz, cloud.labels, attributes={"Cl": chlorophyll})
    first, second = tmp_path / "first.ply", tmp_path / "second.ply"
    with pytest.warns(LidarSigWarning, match="lidar_sig_Cl"):
        ls.Pipeline(scales=ls.knn(10)).run(user).write(first)
    back = ls.read(first)
    np.testing.assert_array_equal(back.attributes["Cl"], chlorophyll)
    assert "lidar_sig_Cl" in back.attributes and "lidar_sig_Cl" in back.previous_outputs
    with pytest.warns(LidarSigWarning, match="lidar_sig_Cl"):
        ls.Pipeline(scales=ls.knn(10)).run(back).write(second)
    again = ls.read(second)
    assert sorted(k for k in again.attributes if k.endswith("Cl")) == ["Cl", "lidar_sig_Cl"]
    np.testing.assert_array_equal(again.attributes["Cl"], chlorophyll)


@pytest.mark.parametrize("ext", [".ply", ".csv"])
def test_las_to_other_format_and_back_keeps_every_dimension(coloured, tmp_path, ext):
    """LAS -> PLY/text -> LAS: the attributes fill the LAS dimensions again, the outputs of the
    first run (marked in the header) are replaced, not doubled."""
    las, result = coloured
    result.write(tmp_path / f"o{ext}")
    again = ls.Pipeline(scales=ls.knn(10)).run(tmp_path / f"o{ext}")
    again.write(tmp_path / "back.laz")
    back = laspy.read(tmp_path / "back.laz")
    assert back.header.point_format.id == las.header.point_format.id == 8
    for name in las.point_format.dimension_names:
        if name not in ("X", "Y", "Z"):  # stored with other scales and offsets
            np.testing.assert_array_equal(np.asarray(back[name]), np.asarray(las[name]), err_msg=name)
    np.testing.assert_allclose(np.column_stack([back.x, back.y, back.z]), result.cloud.xyz, rtol=0, atol=1e-6)
    assert list(back.point_format.extra_dimension_names) == ["Cl", "Cs", "Cp", "Egeom", "GeomClass"]
