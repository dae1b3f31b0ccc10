"""The Python API (issue 9, item 14): every user error raises LidarSigError, a ValueError, at
the call that received the bad value, with a message naming it and the fix."""
import numpy as np
import pytest

import lidar_sig as ls
from conftest import SAMPLES

XYZ = np.random.default_rng(0).uniform(0, 10, (300, 3))


@pytest.fixture(scope="module")
def signature():
    return ls.Pipeline(scales=ls.knn(10)).run(XYZ).signature


CASES = {
    "descriptor None": (lambda s: ls.Pipeline(descriptor=None), "descriptor"),
    "descriptor 42": (lambda s: ls.Pipeline(descriptor=42), "descriptor"),
    "descriptor class": (lambda s: ls.Pipeline(descriptor=ls.plugins.descriptors.c3dcm.C3DCM), "descriptor"),
    "strategy None": (lambda s: ls.Pipeline(strategy=None), "strategy"),
    "max_neighbors text": (lambda s: ls.Pipeline(max_neighbors="many"), "max_neighbors"),
    "weights": (lambda s: ls.Pipeline(weights="heavy"), "weights"),
    "frame": (lambda s: ls.Pipeline(frame=512), "frame"),
    "scales tuple": (lambda s: ls.Pipeline(scales=(10, 20)), "scales"),
    "read columns x,y": (lambda s: ls.read(SAMPLES / "epoch1.laz", columns="x,y"), "x, y and z"),
    "read a number": (lambda s: ls.read(42), "file path"),
    "run a dict": (lambda s: ls.Pipeline().run({"x": 1}), "numpy array"),
    "run (N, 2)": (lambda s: ls.Pipeline().run(XYZ[:, :2]), "(N, 3)"),
    "string labels": (lambda s: ls.Pipeline().run(XYZ, labels=np.array(["roof"] * 300)), "class codes"),
    "fraction labels": (lambda s: ls.Pipeline().run(XYZ, labels=np.full(300, 2.5)), "whole numbers"),
    "negative labels": (lambda s: ls.PointCloud(XYZ, np.full(300, -1)), "class codes"),
    "compare None": (lambda s: ls.compare(s, None), "two signatures"),
    "compare a path": (lambda s: ls.compare(s, "other.h5"), "load_signature"),
    "huge frame": (lambda s: ls.Frame(100000), "4096"),
    "radii text": (lambda s: ls.radii("a"), "numbers"),
    "knn nan": (lambda s: ls.knn(float("nan")), "whole numbers"),
    "knn empty": (lambda s: ls.knn(), "at least one"),
    "unknown rendering": (lambda s: s.sg("pretty"), "rendering"),
    "class table code True": (lambda s: ls.ClassTable("t", ("a",), ((True,),), ((1, 2, 3),)), "whole numbers"),
}


@pytest.mark.parametrize("case", sorted(CASES))
def test_user_error_raises_lidarsigerror_at_the_call(signature, case):
    call, named = CASES[case]
    with pytest.raises(ls.LidarSigError, match=named.replace("(", r"\(").replace(")", r"\)")):
        call(signature)


def test_lidarsigerror_is_a_valueerror():
    assert issubclass(ls.LidarSigError, ValueError)


def test_arrays_run_like_clouds():
    labels = np.random.default_rng(1).choice([2, 6], 300)
    a = ls.Pipeline().run(XYZ, labels=labels)
    b = ls.Pipeline().run(ls.PointCloud(XYZ, labels))
    assert np.array_equal(a.saliency.values, b.saliency.values, equal_nan=True)
    assert "metre (assumed: no CRS)" == a.metadata["units"]
