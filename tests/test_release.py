"""The package as a user installs it, not as a clone: `python -m build` makes the sdist and the
wheel without a warning, both carry the license, and from the wheel installed in a fresh virtual
environment, in a folder outside the checkout, the README's first command writes the report; the
first run there compiles the kernels and says so once, on a stderr that is not a terminal."""
import importlib.util
import os
import shutil
import subprocess
import sys
import sysconfig
import tarfile
import zipfile

import pytest

from conftest import ROOT

needs_build = pytest.mark.skipif(importlib.util.find_spec("build") is None,
                                 reason="the build package is not installed (pip install -e '.[test]')")


@pytest.fixture(scope="module")
def dist(tmp_path_factory):
    """The sdist and wheel of the checkout, built as `python -m build` builds them (without build
    isolation: the test environment has setuptools), and what the build printed. Built from a
    copy of the checkout: the build rewrites the project's lidar_sig.egg-info, whose entry points
    the tests running beside this one (pytest-xdist) read."""
    out = tmp_path_factory.mktemp("dist")
    source = tmp_path_factory.mktemp("checkout") / "lidar_sig"
    shutil.copytree(ROOT, source, ignore=shutil.ignore_patterns(".git", "*.egg-info", "build", "dist", "out",
                                                                 "__pycache__", ".pytest_cache", "report.html"))
    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}  # setuptools warns under it
    built = subprocess.run([sys.executable, "-m", "build", "--no-isolation", "--outdir", str(out), str(source)],
                           capture_output=True, text=True, env=env, timeout=600)
    assert built.returncode == 0, built.stdout + built.stderr
    (sdist,), (wheel,) = out.glob("*.tar.gz"), out.glob("*.whl")
    return sdist, wheel, built.stdout + built.stderr


@needs_build
def test_build_warns_of_nothing_and_both_archives_carry_the_license(dist):
    sdist, wheel, printed = dist
    assert "warning" not in printed.lower(), [line for line in printed.splitlines() if "arning" in line]
    with zipfile.ZipFile(wheel) as whl:
        names = whl.namelist()
        metadata = whl.read(next(n for n in names if n.endswith(".dist-info/METADATA"))).decode()
    assert any(n.endswith(".dist-info/licenses/LICENSE") for n in names)
    assert "License-Expression: BSD-3-Clause" in metadata and "Classifier: Programming Language :: Python :: 3.11" in metadata
    assert "lidar_sig/data/_scene.py" in names and not [n for n in names if "__pycache__" in n]
    with tarfile.open(sdist) as tar:
        members = {m.name.split("/", 1)[1] for m in tar.getmembers() if "/" in m.name}
    # the sdist's tests can run: they, the sample and the pinned test environment are in it
    assert {"LICENSE", "constraints.txt", "data_samples/epoch1.laz", "tests/conftest.py"} <= members


@needs_build
def test_the_readme_first_command_runs_from_the_installed_wheel_and_says_once_that_it_compiles(dist, tmp_path):
    _, wheel, _ = dist
    venv = tmp_path / "venv"
    subprocess.run([sys.executable, "-m", "venv", "--without-pip", str(venv)], check=True, timeout=120)
    python = venv / "bin" / "python"
    installed = subprocess.run([sys.executable, "-m", "pip", "--python", str(python), "install", "--no-deps",
                                "--no-index", "-q", str(wheel)], capture_output=True, text=True, timeout=300)
    assert installed.returncode == 0, installed.stderr
    # the dependencies from this test environment (the wheel alone is under test), after the venv's own
    site = subprocess.run([str(python), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
                          capture_output=True, text=True, check=True).stdout.strip()
    (venv / site.split(str(venv) + "/", 1)[1] / "deps.pth").write_text(
        "\n".join(dict.fromkeys([sysconfig.get_paths()["purelib"], sysconfig.get_paths()["platlib"]])) + "\n")
    work = tmp_path / "elsewhere"  # outside the checkout: no data_samples/ to find
    work.mkdir()
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "NUMBA_CACHE_DIR")}
    env["XDG_CACHE_HOME"] = str(tmp_path / "cache")  # a fresh kernel cache, wherever numba keeps it

    def lidar_sig(*args):
        return subprocess.run([str(venv / "bin" / "lidar-sig"), *map(str, args)], capture_output=True, text=True,
                              cwd=work, env=env, stdin=subprocess.DEVNULL, timeout=900)

    where = subprocess.run([str(python), "-c", "import lidar_sig; print(lidar_sig.__file__)"], capture_output=True,
                           text=True, cwd=work, env=env)
    assert where.stdout.startswith(str(venv)), where.stdout + where.stderr  # the wheel's, not the checkout's
    sample = lidar_sig("sample", "data_samples")
    assert sample.returncode == 0 and (work / "data_samples" / "epoch2.laz").is_file(), sample.stderr
    first = lidar_sig("saliency", "data_samples/epoch1.laz", "-o", "epoch1_sal.laz")
    assert first.returncode == 0, first.stderr
    assert first.stderr.count("compiling the numerical kernels") == 1, first.stderr
    notice = next(line for line in first.stderr.splitlines() if "compiling" in line)
    assert notice.startswith("lidar-sig: note: ") and "once" in notice and "half a minute" in notice
    demo = lidar_sig("compare", "data_samples/epoch1.laz", "data_samples/epoch2.laz", "--report", "report.html",
                     "--overwrite")
    assert demo.returncode == 0 and (work / "report.html").stat().st_size > 100_000, demo.stderr
    assert "compiling" not in demo.stderr  # once: the kernels are cached now
    license_ = subprocess.run([str(python), "-c", "from importlib.metadata import metadata; "
                               "print(metadata('lidar_sig')['License-Expression'])"],
                              capture_output=True, text=True, env=env, cwd=work)
    assert license_.stdout.strip() == "BSD-3-Clause"
