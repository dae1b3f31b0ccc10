"""Hostile inputs to the newest commands, `lidar-sig changes` (issue 17), `lidar-sig catalog`,
`similar` and `outliers` (issue 19), and their Python APIs: each user error is refused in one
line naming the file or value and the fix, with nothing half-written."""
import laspy
import pytest

import lidar_sig as ls
from command_line import run
from conftest import airborne_like
from robustness.helpers import assert_one_line_error, write_las

#: An offset that puts the synthetic scene in Lambert-93 coordinates.
OFFSET = [770500.0, 6277500.0, 0.0]


@pytest.fixture(scope="module")
def scene(tmp_path_factory):
    """The 40 m airborne-like scene as a LAS file, and a copy of it 200 m east."""
    folder = tmp_path_factory.mktemp("scene")
    xyz, labels = airborne_like(3000)
    here = write_las(folder / "here.las", xyz + OFFSET, labels)
    east = write_las(folder / "east.las", xyz + OFFSET + [200.0, 0, 0], labels)
    return here, east


def zero_point_las(path):
    laspy.LasData(laspy.LasHeader(point_format=6, version="1.4")).write(path)
    return path


# -- changes (issue 17) ----------------------------------------------------------------------

@pytest.mark.parametrize("shift", [200.0, 1e6])
def test_changes_refuses_epochs_that_do_not_overlap(tmp_path, shift):
    """Epochs side by side (or far apart) share no land: said so, not 'use a larger cell' or
    'remove far outlying points'."""
    xyz, labels = airborne_like(3000)
    a = write_las(tmp_path / "a.las", xyz + OFFSET, labels)
    b = write_las(tmp_path / "b.las", xyz + OFFSET + [shift, 0, 0], labels)
    proc = run("changes", a, b)
    assert_one_line_error(proc, "a.las", "b.las", "do not overlap")
    with pytest.raises(ls.LidarSigError, match="do not overlap"):
        ls.changes(a, b)


def test_changes_with_a_cell_larger_than_the_survey_advises_a_smaller_cell(scene):
    """With --min-points auto (a fifth of a full cell), a larger cell needs more points, never
    fewer: a cell of 1 km over a 40 m scene must be made smaller."""
    here, _ = scene
    proc = run("changes", here, here, "--cell", "1000")
    assert_one_line_error(proc, "1000 m", "smaller cell size (--cell)")
    assert "larger cell size" not in proc.stderr


# -- catalog (issue 19) ----------------------------------------------------------------------

def test_catalog_of_only_bad_tiles_is_refused_in_one_line(tmp_path, scene):
    """No tile could be computed and there was no catalogue: exit 2, one line naming the file
    and why; no catalogue and no work folder left."""
    bad = zero_point_las(tmp_path / "empty.las")
    out = tmp_path / "out"
    out.mkdir()
    proc = run("catalog", bad, "-o", out / "c.h5", "--workers", "1")
    assert_one_line_error(proc, "empty.las", "no points")
    assert list(out.iterdir()) == []
    with pytest.raises(ls.LidarSigError, match="empty.las"):
        ls.Catalog.build(bad, out / "c.h5")
    assert list(out.iterdir()) == []


def test_catalog_work_dir_that_is_a_file_is_refused(tmp_path, scene):
    here, _ = scene
    not_a_folder = tmp_path / "notes.txt"
    not_a_folder.write_text("mine")
    proc = run("catalog", here, "-o", tmp_path / "c.h5", "--work-dir", not_a_folder, "--workers", "1")
    assert_one_line_error(proc, "notes.txt", "--work-dir")
    assert not_a_folder.read_text() == "mine"
    assert not (tmp_path / "c.h5").exists()


@pytest.mark.parametrize("inputs, backend, what", [(5, None, "an int"), ("TILES", "fast", "backend")])
def test_build_catalog_refuses_values_of_the_wrong_kind(tmp_path, scene, inputs, backend, what):
    from lidar_sig.survey_catalog import build_catalog

    inputs = scene[0] if inputs == "TILES" else inputs
    with pytest.raises(ls.LidarSigError, match=what):
        build_catalog(inputs, tmp_path / "c.h5", backend=backend)
    assert list(tmp_path.iterdir()) == []


# -- similar (issue 19) ----------------------------------------------------------------------

def test_similar_shortlist_below_top_says_why(tmp_path, scene):
    here, east = scene
    made = run("catalog", here, east, "-o", tmp_path / "c.h5", "--workers", "1", "-q")
    assert made.returncode == 0, made.stderr
    proc = run("similar", "here", tmp_path / "c.h5", "--top", "2", "--shortlist", "1")
    assert_one_line_error(proc, "--shortlist", "--top")
