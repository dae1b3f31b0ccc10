"""The command line starts without the libraries it does not use (docs/architecture.md): the help,
`plugins` and a refused option load none of numba, scipy, laspy, h5py, matplotlib and OpenCV
(the help not even numpy), `info` only the reader of its file (and OpenCV for an archive, whose
stored images it checks), and a run numba and numpy but
scipy.spatial, h5py, matplotlib and OpenCV only where it uses them. Each command runs in a fresh
interpreter, whose sys.modules then says what was imported: a test of what is loaded, not of
how long it takes. And the names the packages load on first use are the ones they had."""
import json
import subprocess
import sys
import types

import numpy as np
import pytest

from conftest import SAMPLES

EPOCH2 = SAMPLES / "epoch2.laz"
#: What the command line must not load unless a command computes with it.
SLOW = ("numba", "scipy", "laspy", "h5py", "matplotlib", "cv2")


def loaded(*args, cwd=None):
    """(exit status, set of the modules imported) of `lidar-sig ARGS` run in a fresh interpreter,
    as ``python -m lidar_sig`` runs it (its output is dropped)."""
    code = ("import contextlib, io, json, sys\n"
            "from lidar_sig.__main__ import main\n"
            "with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):\n"
            f"    status = main({[str(a) for a in args]!r})\n"
            "print(json.dumps([status, sorted(sys.modules)]))\n")
    status, modules = json.loads(_python(code, cwd=cwd).splitlines()[-1])
    return status, set(modules)


def _python(code, cwd=None):
    """What ``code`` prints, run in a fresh interpreter (stdin closed); it must succeed."""
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=cwd, timeout=600,
                          stdin=subprocess.DEVNULL)
    assert done.returncode == 0, done.stderr
    return done.stdout


def test_the_check_sees_what_a_command_loads():
    # the test can fail: the same interpreter and check see laspy once a LAS file is read
    status, modules = loaded("info", EPOCH2)
    assert status == 0
    assert {"lidar_sig.cli", "numpy", "laspy"} <= modules
    assert not modules & {"numba", "h5py", "matplotlib", "cv2"}


@pytest.mark.parametrize("args", [["--help"], [], ["saliency", "--help"], ["changes", "--help"]],
                         ids=["help", "no command", "saliency help", "changes help"])
def test_the_help_loads_no_science(args):
    status, modules = loaded(*args)
    assert status == 0
    commands = {m for m in modules if m.startswith("lidar_sig.cli.") and m.rpartition(".")[2] not in
                ("group", "options", "summaries")}
    if args in (["--help"], []):  # the list of commands: each command's module, for its short help
        assert {"lidar_sig.cli.saliency", "lidar_sig.cli.list_plugins", "lidar_sig.cli.changes"} <= commands
    else:  # a command's help: that command's module alone (the others are found, not imported)
        assert commands == {f"lidar_sig.cli.{args[0]}"}, commands
    assert not modules & set(SLOW)
    if args in (["--help"], []):  # the list of commands; a command's help shows choices numpy modules hold
        assert "numpy" not in modules


def test_plugins_loads_the_plugins_not_their_kernels():
    status, modules = loaded("plugins")
    assert status == 0
    assert "lidar_sig.plugins.descriptors.t3dvt_get" in modules
    assert not modules & set(SLOW)


def test_info_of_an_archive_loads_h5py_and_opencv_and_no_other_slow_library(epoch1_archive):
    # OpenCV renders the stored Sg and Sas again from the counts, to flag a stored image that disagrees
    status, modules = loaded("info", epoch1_archive)
    assert status == 0
    assert {"h5py", "cv2"} <= modules
    assert not modules & (set(SLOW) - {"h5py", "cv2"})


@pytest.mark.parametrize("args", [
    ["saliency", EPOCH2, "-o", "out.laz", "--weights", "equal"],
    ["nosuchcommand"],
    ["saliency", EPOCH2, "-o", "out.las.gz"],
    ["compare", EPOCH2, EPOCH2, "--render", "dots"],
    ["changes", EPOCH2, EPOCH2, "--cell", "big"],
    ["changes", EPOCH2, EPOCH2, "--confidence", "2"],
    ["similar", EPOCH2, "catalogue.h5", "--metric", "nearest"],
    ["resilience", EPOCH2, "--fractions", "2"],
], ids=["choice", "no such command", "output format", "render", "cell", "confidence", "metric", "fractions"])
def test_a_refused_option_loads_no_slow_library(args, tmp_path):
    status, modules = loaded(*args, cwd=tmp_path)
    assert status == 2
    assert not modules & set(SLOW)
    assert not list(tmp_path.iterdir())  # nothing written


def test_a_run_loads_numba_and_only_the_libraries_it_uses(tmp_path):
    status, modules = loaded("saliency", EPOCH2, "-o", "out.laz", "-q", cwd=tmp_path)
    assert status == 0 and (tmp_path / "out.laz").exists()
    assert {"numpy", "numba", "laspy"} <= modules
    # no plots, pictures, archives; and every query of this cloud is settled by the voxel grid,
    # so the k-d tree of scipy.spatial is not loaded either
    assert not modules & {"matplotlib", "cv2", "PIL", "selenium", "h5py", "scipy.spatial"}


def test_the_lazy_names_of_io_are_the_names_it_had():
    # a name loaded on first use (PEP 562) is the object its module defines, listed by dir(), and
    # stays so once every submodule is imported (a submodule named like it would replace it);
    # tests/robustness/test_robust_api.py checks the same of lidar_sig's own names
    import importlib
    import pkgutil

    import lidar_sig
    from lidar_sig import io

    for name in io.__all__:
        assert name in dir(io)
        value = getattr(io, name)
        if name in io._EXPORTS:
            assert value is getattr(importlib.import_module(f"lidar_sig.io.{io._EXPORTS[name]}"), name), name
    for info in pkgutil.iter_modules(io.__path__):
        importlib.import_module(f"lidar_sig.io.{info.name}")
    assert not [n for n in io.__all__ + list(io._EXPORTS) if isinstance(getattr(io, n), types.ModuleType)]
    from lidar_sig.io.las import read_las

    assert io.las.read_las is read_las and lidar_sig.read is io.read and io.archive.HDF5_EXTENSIONS == (".h5", ".hdf5")
    assert ".laz" in io.CLOUD_EXTENSIONS and "read_las" not in io.__all__  # a format's names are its own module's


def _fill_the_cache():
    """A default run in a first process, should a test that needs the kernels cached run first
    (a run starts no background load without them)."""
    _python("import lidar_sig as ls, numpy as np\n"
            "ls.Pipeline(progress=False).run(np.random.default_rng(0).uniform(0, 9, (500, 3)))\n")


def test_a_run_loads_its_kernels_in_the_background_before_it_calls_one():
    # in a fresh interpreter: the tiny run loads every kernel of the defaults' search, weights,
    # descriptor and strategy, so that loading overlaps the run's first numpy steps
    _fill_the_cache()
    code = ("import lidar_sig as ls\n"
            "from lidar_sig.numerics import _voxels as grid, kernels\n"
            "thread = ls.Pipeline(progress=False)._warm_up()\n"
            "thread.join()\n"
            "names = [(grid, 'nearest'), (grid, 'third_nearest'),\n"
            "         (kernels, 'covariance_eigenvalues'), (kernels, 'mean_over_scales'), (kernels, 'entropy_rows')]\n"
            "print(sorted(n for m, n in names if not getattr(m, n).signatures))\n")
    assert _python(code).split("\n")[-2] == "[]"


def test_a_failed_background_load_leaves_the_run_as_it_was(monkeypatch):
    # the background run is only a head start: what it fails at, the run proper does itself
    import lidar_sig as ls
    import lidar_sig.base.compile as compile_

    pts = np.random.default_rng(7).uniform(-5, 5, (3000, 3)) * [1, 1, 0.3]
    expected = ls.Pipeline(progress=False).run(pts).saliency.values
    failed = []

    def broken():
        failed.append(True)
        raise RuntimeError("no head start")

    monkeypatch.setattr(compile_, "_WARMING", {})
    monkeypatch.setattr(ls.Pipeline, "_warm_up",
                        lambda self: compile_.warm_up(("c3dcm", "multiscale", "knn", "area"), broken, self.kernels()))
    got = ls.Pipeline(progress=False).run(pts).saliency.values
    assert failed == [True]
    np.testing.assert_array_equal(got, expected)


def test_no_background_run_while_a_kernel_is_to_be_compiled(monkeypatch):
    # numba, compiling, sets sys.stderr and back (colorama): from a second thread that undid a
    # redirection of stderr made meanwhile in the first (an error line lost from a test's capture)
    import lidar_sig as ls
    import lidar_sig.base.compile as compile_

    monkeypatch.setattr(compile_, "_WARMING", {})
    monkeypatch.setattr(compile_, "kernels_cached", lambda *a, **k: False)
    assert ls.Pipeline(progress=False)._warm_up() is None
    monkeypatch.setattr(compile_, "kernels_cached", lambda *a, **k: None)  # cannot be told: no thread either
    assert ls.Pipeline(progress=False)._warm_up() is None
    monkeypatch.setattr(compile_, "kernels_cached", lambda *a, **k: True)
    assert ls.Pipeline(progress=False)._warm_up() is not None


def test_a_background_load_leaves_sys_stderr_alone():
    # numba colours an error message by setting sys.stderr and back (colorama's init and
    # deinit); it builds one when it first loads a cached kernel: that must happen in the
    # caller's thread, not in the background one
    _fill_the_cache()
    code = ("import threading\n"
            "import numba.core.errors as errors\n"
            "if not hasattr(errors, 'init'):\n"
            "    print('no colorama')\n"
            "    raise SystemExit\n"
            "threads = []\n"
            "real = errors.init\n"
            "def init(*a, **k):\n"
            "    threads.append(threading.current_thread().name)\n"
            "    return real(*a, **k)\n"
            "errors.init = init\n"
            "import lidar_sig as ls\n"
            "ls.Pipeline(progress=False).run(__import__('numpy').random.default_rng(0).uniform(0, 9, (500, 3)))\n"
            "print(sorted(set(threads)))\n")
    out = _python(code)
    if out.strip() == "no colorama":
        pytest.skip("numba colours no message here (colorama not installed)")
    assert "lidar-sig kernels" not in out, out


def test_a_plugin_descriptor_is_warmed_up_like_a_built_in(monkeypatch):
    # a plugin declares its kernels (C3DCM's here, which it calls through its own code) and gets
    # the same head start as a built-in; one that declares none gets none (it may compile
    # kernels of its own, which must not compile in a second thread)
    import lidar_sig as ls
    import lidar_sig.base.compile as compile_

    monkeypatch.setattr(compile_, "_WARMING", {})
    monkeypatch.setattr(compile_, "kernels_cached", lambda *a, **k: True)  # as after a first run
    from lidar_sig.plugins import Descriptor
    from lidar_sig.plugins.descriptors.c3dcm import C3DCM

    class Plugin(Descriptor):
        name = "test-plugin"
        kernels = C3DCM.kernels

        def eigenvalues(self, batch):
            return C3DCM().eigenvalues(batch)

    class Undeclared(Plugin):
        name = "test-undeclared"
        kernels = ()

    thread = ls.Pipeline(Plugin())._warm_up()
    assert thread is not None
    thread.join()
    assert ls.Pipeline("t3dvt")._warm_up() is not None
    assert ls.Pipeline(Undeclared())._warm_up() is None
