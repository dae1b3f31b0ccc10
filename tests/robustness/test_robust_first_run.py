"""The first run (issue 9, item 15): compiling the kernels is said once on a terminal, and the
compiled kernels are cached even where the package is installed read-only."""
import os
import shutil
import subprocess
import sys

import pytest

from conftest import ROOT
from robustness.helpers import mounted_tmpfs

RUN = ("import numpy as np, lidar_sig as ls\n"
       "ls.Pipeline(progress=True).run(np.random.default_rng(0).uniform(0, 10, (3000, 3)))\n"
       "from lidar_sig.base.compile import kernels_cached\nprint('cached', kernels_cached(ls.Pipeline().kernels()))\n")


def test_read_only_install_compiles_once_into_the_user_cache_and_says_so(tmp_path):
    with mounted_tmpfs(tmp_path, size="64m") as fs:
        shutil.copytree(ROOT / "lidar_sig", fs / "lidar_sig", ignore=shutil.ignore_patterns("__pycache__"))
        made = subprocess.run(["mount", "-o", "remount,ro", str(fs)], capture_output=True, text=True)
        if made.returncode != 0:
            pytest.skip(f"cannot make the copy read-only ({made.stderr.strip()})")
        cache = tmp_path / "cache"
        env = dict(os.environ, PYTHONPATH=str(fs), XDG_CACHE_HOME=str(cache))
        env.pop("NUMBA_CACHE_DIR", None)
        first = subprocess.run([sys.executable, "-c", RUN], capture_output=True, text=True, env=env, cwd=tmp_path,
                               timeout=600)
        assert first.returncode == 0, first.stderr
        assert "compiling the numerical kernels" in first.stderr and "cached True" in first.stdout
        assert list(cache.glob("numba/*/*.nbi")), "numba did not fall back to the user cache folder"
        second = subprocess.run([sys.executable, "-c", RUN], capture_output=True, text=True, env=env,
                                cwd=tmp_path, timeout=600)
        assert second.returncode == 0 and "compiling" not in second.stderr and "cached True" in second.stdout
