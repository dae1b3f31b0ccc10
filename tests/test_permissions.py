"""Outputs are readable by others as any ordinary file is: modes follow the umask; an overwritten
file keeps its mode (issue 10)."""
import os
import stat

import pytest

import lidar_sig as ls
from conftest import airborne_like

FORMATS = [".las", ".laz", ".ply", ".pcd", ".xyz", ".csv", ".h5", ".png"]


@pytest.fixture(scope="module")
def result():
    xyz, labels = airborne_like(n=1500)
    return ls.Pipeline(scales=ls.knn(10)).run(ls.PointCloud(xyz + [500000.0, 5400000.0, 0.0], labels))


@pytest.fixture
def umask():
    """Set the process umask for one test and restore it afterwards."""
    old = os.umask(0o022)
    yield os.umask
    os.umask(old)


def _mode(path):
    return stat.S_IMODE(os.stat(path).st_mode)


@pytest.mark.parametrize("ext", FORMATS)
def test_new_output_mode_follows_the_umask(result, tmp_path, umask, ext):
    umask(0o022)
    result.write(tmp_path / f"a{ext}")
    assert _mode(tmp_path / f"a{ext}") == 0o644
    umask(0o027)
    result.write(tmp_path / f"b{ext}")
    assert _mode(tmp_path / f"b{ext}") == 0o640


@pytest.mark.parametrize("ext", [".laz", ".ply", ".h5"])
def test_overwritten_output_keeps_its_mode(result, tmp_path, umask, ext):
    umask(0o022)
    path = tmp_path / f"o{ext}"
    path.write_bytes(b"old")
    os.chmod(path, 0o664)
    result.write(path, overwrite=True)
    assert _mode(path) == 0o664 and path.read_bytes() != b"old"
