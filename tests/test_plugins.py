"""Third-party plugins arrive through real entry points (a distribution's metadata on sys.path)."""
import os
import subprocess
import sys
import textwrap

import laspy
import numpy as np
import pytest

import lidar_sig as ls
from lidar_sig.numerics.neighbors import NeighborIndex
from lidar_sig.plugins import Descriptor
from lidar_sig.plugins.descriptors.c3dcm import C3DCM

from conftest import ROOT, SAMPLES, airborne_like

PLUGIN = '''
"""A third-party descriptor: C3DCM eigenvalues squared (sharper saliency)."""
from lidar_sig.plugins import Descriptor
from lidar_sig.plugins.descriptors.c3dcm import C3DCM


class Squared(Descriptor):
    name = "demo-squared"
    summary = "squared covariance eigenvalues (test plugin)"

    def eigenvalues(self, batch):
        return C3DCM().eigenvalues(batch) ** 2
'''


def _install_fake_distribution(folder):
    (folder / "lidar_sig_demo_plugin.py").write_text(PLUGIN)
    info = folder / "lidar_sig_demo_plugin-0.1.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: lidar-sig-demo-plugin\nVersion: 0.1\n")
    (info / "entry_points.txt").write_text(
        "[lidar_sig.descriptors]\ndemo-squared = lidar_sig_demo_plugin:Squared\n")


def _run(folder, *args):
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(folder), str(ROOT)]))
    return subprocess.run([sys.executable, *args], capture_output=True, text=True, env=env, timeout=600)


def test_third_party_descriptor_through_entry_point(tmp_path):
    _install_fake_distribution(tmp_path)
    listed = _run(tmp_path, "-m", "lidar_sig", "plugins")
    assert listed.returncode == 0, listed.stderr
    line = next(ln for ln in listed.stdout.splitlines() if "demo-squared" in ln)
    assert "lidar-sig-demo-plugin" in line and "squared covariance" in line
    for name in ("c3dcm", "t3dvt", "t3dvt-get"):
        assert name in listed.stdout

    out = tmp_path / "out.laz"
    cli = _run(tmp_path, "-m", "lidar_sig", "saliency", SAMPLES / "epoch1.laz", "-o", out,
               "--descriptor", "demo-squared", "-q")
    assert cli.returncode == 0, cli.stderr
    assert "Cl" in laspy.read(out).point_format.extra_dimension_names

    code = textwrap.dedent(f"""
        import numpy as np, lidar_sig as ls
        a = ls.Pipeline(descriptor="demo-squared").run({str(SAMPLES / 'epoch1.laz')!r})
        b = ls.Pipeline(descriptor="c3dcm").run({str(SAMPLES / 'epoch1.laz')!r})
        ok = a.saliency.defined
        # squaring eigenvalues sharpens: more line-type, less point-type on average
        print(a.metadata["descriptor"], np.nanmean(a.saliency.cp[ok]) < np.nanmean(b.saliency.cp[ok]))
    """)
    api = _run(tmp_path, "-c", code)
    assert api.returncode == 0, api.stderr
    assert api.stdout.split() == ["demo-squared", "True"]


def test_unknown_descriptor_on_command_line_lists_plugins(tmp_path):
    proc = _run(tmp_path, "-m", "lidar_sig", "saliency", SAMPLES / "epoch1.laz", "-o", tmp_path / "o.laz",
                "--descriptor", "nope")
    assert proc.returncode == 2
    assert "available: c3dcm, t3dvt, t3dvt-get" in proc.stderr


class Ascending(Descriptor):
    """C3DCM's eigenvalues given in ascending order, as numpy.linalg.eigvalsh returns them."""

    name = "ascending"

    def eigenvalues(self, batch):
        return C3DCM().eigenvalues(batch)[..., ::-1]


class Negative(Descriptor):
    """C3DCM's eigenvalues with the smallest set to -offset times the largest."""

    name = "negative"

    def __init__(self, offset):
        self.offset = offset

    def eigenvalues(self, batch):
        ev = C3DCM().eigenvalues(batch)
        ev[..., 2] = -self.offset * ev[..., 0]
        return ev


@pytest.fixture(scope="module")
def batch():
    xyz, _ = airborne_like(2000, seed=8)
    index = NeighborIndex(xyz - xyz.mean(axis=0), "knn", np.array([10, 20]))
    return index.query(index.blocks()[0])


def test_a_plugin_giving_ascending_eigenvalues_gets_the_saliency_of_descending_ones(batch):
    expected = C3DCM().saliency(batch)
    got = Ascending().saliency(batch)
    assert np.isfinite(expected).all()
    np.testing.assert_allclose(got, expected, rtol=0, atol=1e-12)
    assert (got >= 0).all()  # inside the triangle: no negative Cl or Cs


def test_round_off_negative_eigenvalues_are_zero_and_clearly_negative_ones_refused(batch):
    zero = C3DCM().eigenvalues(batch)
    zero[..., 2] = 0.0
    from lidar_sig.method.saliency_map import saliency_from_eigenvalues

    np.testing.assert_allclose(Negative(1e-12).saliency(batch), saliency_from_eigenvalues(zero), atol=1e-12)
    with pytest.raises(ls.LidarSigError, match="'negative'.*negative eigenvalue"):
        Negative(0.1).saliency(batch)


KERNEL_PLUGIN = '''
"""A third-party descriptor with a compiled kernel of its own, declared as a built-in's are."""
import numba
import numpy as np

from lidar_sig.plugins import Descriptor
from lidar_sig.plugins.descriptors.c3dcm import C3DCM


@numba.njit(cache=True)
def square(values):
    out = np.empty_like(values)
    for i in range(values.size):
        out[i] = values[i] * values[i]
    return out


class KernelSquared(Descriptor):
    name = "demo-kernel"
    summary = "squared covariance eigenvalues, squared by a kernel (test plugin)"
    kernels = C3DCM.kernels + (("lidar_sig_demo_kernel", ("square",)),)

    def eigenvalues(self, batch):
        ev = np.ascontiguousarray(C3DCM().eigenvalues(batch))
        return square(ev.reshape(-1)).reshape(ev.shape)
'''


def test_a_plugin_of_another_distribution_runs_in_tiles_and_is_warmed_up_like_a_built_in(tmp_path):
    (tmp_path / "lidar_sig_demo_kernel.py").write_text(KERNEL_PLUGIN)
    info = tmp_path / "lidar_sig_demo_kernel-0.1.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: lidar-sig-demo-kernel\nVersion: 0.1\n")
    (info / "entry_points.txt").write_text("[lidar_sig.descriptors]\ndemo-kernel = lidar_sig_demo_kernel:KernelSquared\n")
    from lidar_sig.tiling.memory import MIB, block_bytes

    small = f"{(block_bytes(41_507) - 1) // MIB}MiB"  # just below what the sample needs as one block
    one, tiled = tmp_path / "one.laz", tmp_path / "tiled.laz"
    done = _run(tmp_path, "-m", "lidar_sig", "saliency", SAMPLES / "epoch1.laz", "-o", one, "--descriptor",
                "demo-kernel")
    assert done.returncode == 0, done.stderr
    done = _run(tmp_path, "-m", "lidar_sig", "saliency", SAMPLES / "epoch1.laz", "-o", tiled, "--descriptor",
                "demo-kernel", "--memory", small)
    assert done.returncode == 0 and "memory budget as one block: processed in" in done.stdout, done.stdout + done.stderr
    a, b = laspy.read(one), laspy.read(tiled)
    for dim in ("Cl", "Cs", "Cp"):  # the same values from tiles, to float32 round-off (test_memory_budget)
        np.testing.assert_allclose(np.asarray(a[dim]), np.asarray(b[dim]), rtol=0, atol=1e-6)
    code = textwrap.dedent("""
        import lidar_sig as ls
        from lidar_sig.base.compile import kernels_cached
        pipe = ls.Pipeline("demo-kernel")
        names = [n for module, names in pipe.kernels() for n in names]
        thread = pipe._warm_up()
        print("square" in names, kernels_cached(pipe.kernels()), thread is not None)
    """)
    warm = _run(tmp_path, "-c", code)
    assert warm.returncode == 0, warm.stderr
    assert warm.stdout.split() == ["True", "True", "True"]  # its kernel listed, cached after a run, warmed up


def test_a_source_tree_never_installed_says_to_install_it(monkeypatch):
    # the built-ins come from lidar_sig's own entry points; without them the error says what to do
    from lidar_sig.base import extensions
    from lidar_sig.base.errors import LidarSigError
    from lidar_sig.plugins import available

    monkeypatch.setattr(extensions, "entry_points", lambda group: [])
    extensions.forget()
    try:
        for kind in extensions.GROUPS:
            with pytest.raises(LidarSigError, match=r"not registered: install it \(pip install -e \."):
                extensions.registered(kind)
        with pytest.raises(LidarSigError, match="descriptors .* not registered"):
            available("descriptor")
    finally:
        extensions.forget()
