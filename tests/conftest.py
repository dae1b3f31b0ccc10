"""Shared fixtures: the real survey data beside the project, and small synthetic clouds."""
import os
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT.parent / "shared" / "data"
IGN = DATA / "ign_lidarhd_montpellier"
IGN_FILES = sorted(IGN.glob("*.laz"))
SAMPLES = ROOT / "data_samples"

# Many tests compare stderr exactly: no progress lines in them, in this process or in the commands
# it starts (they inherit the variable). tests/test_progress.py checks the lines with it unset.
os.environ["LIDAR_SIG_PROGRESS"] = "none"


def need_data(path):
    """Skip (saying why) when the shared survey data is not beside the project."""
    if not Path(path).exists():
        pytest.skip(f"real survey data not found at {path} (expected ../shared/data beside the project)")
    return Path(path)


def airborne_like(n=4000, seed=0, quantum=2.0 ** -10):
    """A small airborne-like scene: bumpy ground, a box roof, a tree blob; labels 2, 6, 5.

    Coordinates are quantized to ``quantum`` (as LAS stores integers) so that adding a
    UTM-sized offset is exact in float64.
    """
    rng = np.random.default_rng(seed)
    n_ground, n_roof, n_tree = n // 2, n // 4, n - n // 2 - n // 4
    g = rng.uniform(0, 40, (n_ground, 2))
    ground = np.column_stack([g, 0.3 * np.sin(g[:, 0] / 5) + 0.02 * rng.standard_normal(n_ground)])
    r = rng.uniform(5, 15, (n_roof, 2))
    roof = np.column_stack([r, 8 + 0.4 * np.abs(r[:, 0] - 10) + 0.02 * rng.standard_normal(n_roof)])
    tree = rng.normal([28, 28, 7], [1.5, 1.5, 1.5], (n_tree, 3))
    xyz = np.vstack([ground, roof, tree])
    labels = np.repeat([2, 6, 5], [n_ground, n_roof, n_tree])
    if quantum:
        xyz = np.round(xyz / quantum) * quantum
    return xyz, labels


# -- computed once per test run -----------------------------------------------------------------
# Shared results: a test that changes one must work on a copy.

@pytest.fixture(scope="session")
def default_run():
    """``default_run(path)``: ``ls.Pipeline(progress=False).run(path)`` (the defaults: C3DCM,
    Multiscale over k = 20, 30, 40, area weights), computed once per path for the whole run."""
    import lidar_sig as ls

    results = {}

    def run(path):
        path = need_data(path)
        if path not in results:
            results[path] = ls.Pipeline(progress=False).run(path)
        return results[path]
    return run


@pytest.fixture(scope="session")
def epoch1_archive(tmp_path_factory):
    """The signature archive of data_samples/epoch1.laz made by `lidar-sig signature` with the
    defaults (copy it before editing it)."""
    from command_line import run

    path = tmp_path_factory.mktemp("archive") / "epoch1.h5"
    made = run("signature", SAMPLES / "epoch1.laz", "-o", path, "-q")
    assert made.returncode == 0, made.stderr
    return path


#: Points of :func:`noisy_las` left out by default: withheld, class 7 (low noise), 18 (high noise).
NOISY = {"withheld": 40, 7: 30, 18: 30}


def noisy_las(path, n=3000, seed=11, version="1.4", point_format=6):
    """A LAS file of the :func:`airborne_like` scene (first ``n`` points) followed by points to
    leave out: NOISY["withheld"] withheld points on the ground, NOISY[7] low points below it
    (class 7) and NOISY[18] high noise above it (class 18). Returns the (N,) mask of the scene."""
    import laspy

    xyz, labels = airborne_like(n, seed=seed)
    rng = np.random.default_rng(seed + 1)
    extra = {"withheld": np.column_stack([rng.uniform(0, 40, (NOISY["withheld"], 2)), np.zeros(NOISY["withheld"])]),
             7: np.column_stack([rng.uniform(0, 40, (NOISY[7], 2)), rng.uniform(-8, -3, NOISY[7])]),
             18: np.column_stack([rng.uniform(0, 40, (NOISY[18], 2)), rng.uniform(40, 90, NOISY[18])])}
    all_xyz = np.vstack([xyz, *extra.values()])
    classes = np.concatenate([labels, np.full(NOISY["withheld"], 2), np.full(NOISY[7], 7), np.full(NOISY[18], 18)])
    withheld = np.zeros(len(all_xyz), bool)
    withheld[n:n + NOISY["withheld"]] = True
    las = laspy.create(point_format=point_format, file_version=version)
    las.header.scales = np.array([2.0 ** -10] * 3)  # airborne_like's quantum: coordinates exact
    las.header.offsets = np.zeros(3)
    las.x, las.y, las.z = all_xyz[:, 0], all_xyz[:, 1], all_xyz[:, 2]
    las.classification = classes
    las.withheld = withheld
    las.write(path)
    scene = np.zeros(len(all_xyz), bool)
    scene[:n] = True
    return scene


def compile_every_kernel():
    """Run every descriptor, strategy, kind of scale and weighting once on a small cloud, so that
    each kernel is compiled and cached (later calls load it from the cache)."""
    import lidar_sig as ls

    xyz, labels = airborne_like(600)
    for descriptor in ("c3dcm", "t3dvt", "t3dvt-get"):
        for strategy in ("multiscale", "optimal"):
            for scales in (ls.knn(6, 10), ls.radii(2.0, 3.0)):
                for weights in ("area", "none"):
                    ls.Pipeline(descriptor, strategy, scales, weights=weights, progress=False).run(xyz, labels=labels)


def pytest_sessionstart(session):
    """With the tests spread over processes (pytest-xdist's -n), the controlling process
    compiles the kernels once before the workers start (xdist starts them after this hook), so
    that the workers load them from the cache instead of each compiling the same kernels."""
    config = session.config
    if not hasattr(config, "workerinput") and getattr(config.option, "numprocesses", None):
        compile_every_kernel()


@pytest.fixture(scope="session", autouse=True)
def compiled_kernels():
    """Every kernel compiled and cached before the first test, as after a first run: a test's
    stderr then holds its own lines, not the first run's compilation notice, on a fresh machine
    as here (tests/test_release.py and tests/robustness/test_robust_first_run.py check that
    notice, each on a cache of its own). Under pytest-xdist the kernels are in the cache
    already (:func:`pytest_sessionstart`) and each worker loads them."""
    compile_every_kernel()
