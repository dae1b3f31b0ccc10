"""The sample a change map's cells take of a dense epoch (docs/changes.md, "The points a cell's
signature takes"): a uniform share of the points chosen by their keys, whatever their order;
each sampled point's saliency is the one a run on every point gives; the rules count the
sample."""
import numpy as np
import pytest

import lidar_sig as ls
from conftest import IGN_FILES, SAMPLES
from lidar_sig.change_map import (SAMPLE_DENSITY, changes, compute_epoch, density, in_sample, read_epoch,
                                  sample_fraction)


@pytest.fixture(scope="module")
def ign():
    if not IGN_FILES:
        pytest.skip("the IGN tiles of ../shared/data are not beside the project")
    return read_epoch(list(IGN_FILES))


def test_the_sample_is_a_uniform_share_of_the_points_whatever_their_order(ign):
    mask = in_sample(ign.xyz, ign.labels, 0.25)
    assert abs(mask.mean() - 0.25) < 0.005
    for code in np.unique(ign.labels):  # no class is favoured
        mine = ign.labels == code
        if mine.sum() >= 20_000:
            assert abs(mask[mine].mean() - 0.25) < 0.02, code
    shuffled = np.random.default_rng(3).permutation(len(ign))
    assert np.array_equal(in_sample(ign.xyz[shuffled], ign.labels[shuffled], 0.25), mask[shuffled])
    assert in_sample(ign.xyz, ign.labels, 1.0) is None
    assert sample_fraction(SAMPLE_DENSITY / 2) == 1.0
    assert sample_fraction(4 * SAMPLE_DENSITY) == pytest.approx(0.25)


def test_a_sampled_point_s_saliency_is_the_one_a_run_on_every_point_gives():
    cloud = ls.read(SAMPLES / "epoch1.laz")
    pipe = ls.Pipeline(progress=False)
    whole, _ = pipe.saliency(cloud)
    query = in_sample(cloud.xyz, cloud.labels, 0.3)
    part, stats = pipe.saliency(cloud, query=query)
    assert stats["n_queried"] == int(query.sum())
    np.testing.assert_allclose(part.values[query], whole.values[query], rtol=1e-12, atol=1e-15)
    assert np.isnan(part.values[~query]).all()
    whole_map = changes(cloud, ls.read(SAMPLES / "epoch2_aligned.laz"), pipeline=pipe, sample_density=None)
    assert whole_map.sample_text() == "" and whole_map.sampled == whole_map.density
    with pytest.raises(ls.LidarSigError, match="one bool per point"):
        pipe.saliency(cloud, query=query[:-1])


def test_a_dense_epoch_s_cells_take_its_sample_and_the_rules_count_it(ign):
    pipe = ls.Pipeline(progress=False)
    cm = changes(list(IGN_FILES), list(IGN_FILES), pipeline=pipe, cell=25)
    d = density(ign.xyz[:, :2])
    assert cm.density == pytest.approx((d, d))
    assert d > SAMPLE_DENSITY and cm.sampled == pytest.approx((SAMPLE_DENSITY, SAMPLE_DENSITY))
    assert cm.min_points == round(0.2 * SAMPLE_DENSITY * 25 ** 2)
    assert cm.sample_text() == f"the cells take a sample of {SAMPLE_DENSITY:g} points/m²"  # the CLI and report say it
    from lidar_sig.reporting._changes_page import settings_text

    assert cm.sample_text() in settings_text(cm)
    points = cm.table["points_a"]
    expected = np.bincount(cm.grid.cell_of(ign.xyz[:, :2]), minlength=cm.grid.n_cells) * SAMPLE_DENSITY / d
    full = points >= 500
    assert full.sum() >= 10
    np.testing.assert_allclose(points[full], expected[full], rtol=0.1)  # a share f of each cell's points
    assert cm.n_significant == 0  # an epoch against itself: the same sample on both sides
    # an epoch computed whole beforehand gives its cells the same sample: the same map
    given = compute_epoch(list(IGN_FILES), pipe)
    again = changes(given, list(IGN_FILES), pipeline=pipe, cell=25)
    for k in ("points_a", "points_b", "valid", "coverage"):
        assert np.array_equal(again.table[k], cm.table[k]), k
    np.testing.assert_allclose(again.table["score"], cm.table["score"], rtol=1e-9, equal_nan=True)


@pytest.mark.parametrize("bad", [0, -5, float("nan"), float("inf"), True, "dense"])
def test_a_bad_sample_density_is_refused_at_the_call_before_any_file_is_read(bad, tmp_path):
    with pytest.raises(ls.LidarSigError, match="sample_density must be a positive number"):
        changes(tmp_path / "missing_a.laz", tmp_path / "missing_b.laz", sample_density=bad)


@pytest.mark.parametrize("bad", ["0", "-1", "nan", "inf", "dense"])
def test_the_command_line_refuses_a_bad_sample_density_in_one_line(bad, tmp_path):
    from command_line import run
    from robustness.helpers import assert_one_line_error

    proc = run("changes", SAMPLES / "epoch1.laz", SAMPLES / "epoch2_aligned.laz", "--sample-density", bad,
               "-o", tmp_path / "map.tif")
    assert_one_line_error(proc, "--sample-density", bad)
    assert not (tmp_path / "map.tif").exists()
