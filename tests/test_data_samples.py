"""The embedded sample is exactly what the script in the repository makes."""
import subprocess
import sys

import laspy
import numpy as np

from conftest import SAMPLES


def test_make_scene_regenerates_committed_samples(tmp_path):
    subprocess.run([sys.executable, str(SAMPLES / "make_scene.py"), "--out", str(tmp_path)],
                   check=True, capture_output=True)
    for name in ("epoch1.laz", "epoch2.laz"):
        made, kept = laspy.read(tmp_path / name), laspy.read(SAMPLES / name)
        assert len(made.points) == len(kept.points) > 20000
        for dim in kept.point_format.dimension_names:
            assert np.array_equal(np.asarray(made[dim]), np.asarray(kept[dim])), (name, dim)
        assert set(np.unique(kept.classification)) >= {2, 5, 6}
