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
    "compare None": (lambda s: ls.compare(s, None), "b is None"),
    "compare a missing path": (lambda s: ls.compare(s, "other.h5"), "other.h5: no such file"),
    "huge frame": (lambda s: ls.Frame(100000), "4096"),
    "radii text": (lambda s: ls.radii("a"), "numbers"),
    "knn nan": (lambda s: ls.knn(float("nan")), "whole numbers"),
    "knn empty": (lambda s: ls.knn(), "at least one"),
    "unknown rendering": (lambda s: s.sg("pretty"), "rendering"),
    "class table code True": (lambda s: ls.ClassTable("t", ("a",), ((True,),), ((1, 2, 3),)), "whole numbers"),
    "class table names twice": (lambda s: ls.ClassTable("t", ("a", "a"), ((2,), (3,)), ((1, 2, 3),) * 2), "'a'"),
    "class named other": (lambda s: ls.ClassTable("t", ("other",), ((2,),), ((1, 2, 3),)), "'other'"),
    "color_bins -1": (lambda s: ls.compare(s, s, color_bins=-1), "color_bins"),
    "color_bins None": (lambda s: ls.compare(s, s, color_bins=None), "color_bins"),
    "color_bins 1.5": (lambda s: ls.compare(s, s, color_bins=1.5), "color_bins"),
    "compare an array": (lambda s: ls.compare(s, XYZ), "b is a ndarray"),
    "read an array": (lambda s: ls.read(XYZ), "got a ndarray"),
    "read an empty path": (lambda s: ls.read(""), "empty path"),
    "complex coordinates": (lambda s: ls.Pipeline().run(XYZ.astype(complex)), "numbers"),
    "load_signature None": (lambda s: ls.load_signature(None), "file path"),
    "load_signature missing": (lambda s: ls.load_signature("missing.h5"), "no such file"),
    "run_set work None": (lambda s: ls.run_set(ls.Pipeline(), [SAMPLES / "epoch1.laz"], work=None), "work"),
    "run_set no input": (lambda s: ls.run_set(ls.Pipeline(), [], work="w"), "at least one"),
    "resilience seed -1": (lambda s: ls.resilience(XYZ, seed=-1), "seed"),
    "resilience tiny fraction": (lambda s: ls.resilience(XYZ, fractions=(0.01,)), "fraction 0.01 keeps 3"),
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


def test_result_write_refuses_a_bad_path_or_overwrite(tmp_path):
    result = ls.Pipeline(scales=ls.knn(10)).run(XYZ)
    for path, named in ((None, "file path"), (3, "got an int")):
        with pytest.raises(ls.LidarSigError, match=named):
            result.write(path)
    (tmp_path / "o.laz").write_bytes(b"keep")
    with pytest.raises(ls.LidarSigError, match="overwrite must be True or False"):
        result.write(tmp_path / "o.laz", overwrite="no")
    assert (tmp_path / "o.laz").read_bytes() == b"keep"


def test_public_functions_stay_functions_after_their_modules_are_imported():
    # a submodule named like a public function would replace it on the package once imported
    import subprocess
    import sys

    # every module of the package imported, then each public name the stub takes from a module
    # (not the submodules it lists) must still be that module's object
    code = ("import ast, importlib, pkgutil, types, lidar_sig as ls\n"
            "for info in pkgutil.walk_packages(ls.__path__, 'lidar_sig.'):\n"
            "    importlib.import_module(info.name)\n"
            "stub = ast.parse(open(ls.__file__ + 'i').read())\n"
            "names = {a.asname or a.name: (n.module, a.name) for n in stub.body\n"
            "         if isinstance(n, ast.ImportFrom) and n.module for a in n.names}\n"
            "def owner(n):\n"
            "    module, name = names[n]\n"
            "    return getattr(importlib.import_module('lidar_sig.' + module), name)\n"
            "bad = [n for n in names if getattr(ls, n) is not owner(n)\n"
            "       or isinstance(getattr(ls, n), types.ModuleType) != (n in ('errors', 'progress', 'signature'))]\n"
            "print(sorted(names) == sorted(set(ls.__all__) - {'catalog', 'change_map', 'data', 'io', 'jobs',\n"
            "                                           'metrics', 'plugins', 'reporting', 'tiling'}), bad)\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0 and out.stdout.strip() == "True []", out.stdout + out.stderr
