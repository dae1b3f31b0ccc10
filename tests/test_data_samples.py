"""The embedded sample: the repository's data_samples/ is exactly what the package makes, and
`lidar-sig sample` writes it where an installed package has no data_samples/."""
import laspy
import numpy as np

from command_line import run
from conftest import SAMPLES
from lidar_sig.data import SAMPLE_FILES, write_sample
from robustness.helpers import assert_one_line_error


def test_the_package_makes_the_committed_samples_byte_for_byte(tmp_path):
    written = write_sample(tmp_path / "made")
    assert [f.path.name for f in written] == list(SAMPLE_FILES) and all(f.written for f in written)
    for f in written:
        assert f.path.read_bytes() == (SAMPLES / f.path.name).read_bytes(), f.path.name
        assert len(laspy.read(f.path).points) == f.points > 20000
    kept = laspy.read(SAMPLES / "epoch1.laz")
    assert set(np.unique(kept.classification)) >= {2, 5, 6}


def test_sample_command_writes_the_files_then_keeps_them_and_refuses_other_files(tmp_path):
    done = run("sample", tmp_path / "demo")
    assert done.returncode == 0, done.stderr
    assert done.stdout.splitlines()[0] == f"wrote {tmp_path / 'demo' / 'epoch1.laz'} (41,507 points)"
    again = run("sample", tmp_path / "demo")
    assert again.returncode == 0 and all(line.startswith("kept ") for line in again.stdout.splitlines())
    (tmp_path / "demo" / "epoch2.laz").write_bytes(b"mine")
    refused = run("sample", tmp_path / "demo")
    assert_one_line_error(refused, "epoch2.laz")
    assert "--overwrite" in refused.stderr and (tmp_path / "demo" / "epoch2.laz").read_bytes() == b"mine"
    replaced = run("sample", tmp_path / "demo", "--overwrite")
    assert replaced.returncode == 0 and "wrote" in replaced.stdout
    assert (tmp_path / "demo" / "epoch2.laz").read_bytes() == (SAMPLES / "epoch2.laz").read_bytes()


def test_sample_command_refuses_a_folder_it_cannot_make_and_leaves_nothing(tmp_path):
    assert_one_line_error(run("sample", tmp_path / "missing" / "demo"), "parent does not exist")
    (tmp_path / "file").write_text("x")
    assert_one_line_error(run("sample", tmp_path / "file"), "is a file")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["file"]
