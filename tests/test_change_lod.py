"""The change map's level of detection (issue 17): the model on arrays of known distribution, then
on real data: unchanged pairs give few significant cells, known edits are significant and rank
first, a sparse pair of two class schemes gives a map with no options, and a series of three
epochs puts each edit in its interval. Each epoch's saliency is computed once per module."""
import sys
import warnings

import numpy as np
import pytest

from conftest import IGN, ROOT, need_data
from lidar_sig.change_map import Level, changes, compute_epoch, level_of_detection, read_epoch
from lidar_sig.change_map._lod import MIN_CELLS, quantile
from lidar_sig.base.errors import LidarSigWarning

sys.path.insert(0, str(ROOT / "benchmarks"))


# -- the model on arrays ----------------------------------------------------------------------

def test_unchanged_cells_of_two_different_surveys_are_rarely_significant_and_a_change_stands_out():
    rng = np.random.default_rng(1)
    n, replicates = 4000, 6
    mu = rng.lognormal(-3.0, 1.0, n)  # each cell's score of unchanged land, sampled as it is
    null = mu[:, None] * rng.lognormal(0.0, 0.3, (n, replicates))
    # the second survey multiplies every cell's score by 5 (density, noise, scheme), cell to cell
    # by a factor of spread 0.4, and its own sampling adds the spread of the replicates
    scores = mu * 5.0 * rng.lognormal(0.0, 0.4, n) * rng.lognormal(0.0, 0.3, n)
    scores[:20] *= 100.0  # twenty changed cells
    level = level_of_detection(scores, null, np.ones(n, bool))
    assert isinstance(level, Level) and level.survey
    assert np.exp(level.beta) == pytest.approx(5.0, rel=0.1)
    unchanged = level.significant[20:].mean()
    assert 0.005 < unchanged < 0.05  # 95% one-sided, conservative (tau holds the sampling spread)
    assert level.significant[:20].all() and (level.z[:20] > quantile(0.95)).all()
    assert np.array_equal(level.significant, scores > level.lod)
    stricter = level_of_detection(scores, null, np.ones(n, bool), confidence=0.99)
    assert (stricter.lod > level.lod).all() and stricter.significant.sum() < level.significant.sum()


def test_with_few_cells_the_level_covers_sampling_noise_only():
    rng = np.random.default_rng(2)
    null = rng.lognormal(-3.0, 0.2, (MIN_CELLS - 1, 6))
    scores = np.exp(-3.0) * np.array([1, 1, 1, 1, 1, 1, 8.0])
    level = level_of_detection(scores, null, np.ones(MIN_CELLS - 1, bool))
    assert not level.survey and level.beta == 0.0 and level.tau == 0.0
    assert level.significant.tolist() == [False] * 6 + [True]


def test_a_cell_whose_second_epoch_holds_one_class_is_significant_when_it_changed():
    # a cell whose buildings were all removed: the resamples of epoch B (ground only) compare
    # exactly equal (delta_KL 0) while those of A do not; the spread of the replicates' logs,
    # with the zeros floored at 1e-12, made its level of detection 42,252 against a score of 5.6
    rng = np.random.default_rng(5)
    null = rng.lognormal(np.log(5e-4), 0.8, (16, 6))
    scores = null.mean(axis=1) * rng.lognormal(0.0, 0.3, 16)
    null[11] = [1.8e-3, 1.4e-4, 9.7e-4, 0.0, 0.0, 0.0]
    scores[11] = 5.6
    level = level_of_detection(scores, null, np.ones(16, bool))
    assert level.sigma[11] < 2.0 and level.lod[11] < 0.1
    assert level.significant.tolist() == [c == 11 for c in range(16)]


def test_cells_not_compared_undefined_metrics_and_identical_cells_give_no_significance():
    null = np.array([[0.0, 0.0, 0.0, 0.0], [0.1, 0.2, 0.1, 0.15], [0.1, 0.1, 0.1, 0.1]] * 4)
    scores = np.array([0.0, 0.12, np.nan] * 4)
    valid = np.array([True, True, True] * 3 + [False] * 3)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no log of zero, no 0/0
        level = level_of_detection(scores, null, valid)
    assert not level.significant[0] and np.isfinite(level.lod[0])  # identical cells: nothing changed
    assert np.isnan(level.lod[2]) and not level.significant[2]  # metric undefined there
    assert np.isnan(level.lod[9:]).all() and not level.significant[9:].any()  # not compared


# -- real data: the IGN block ---------------------------------------------------------------------

@pytest.fixture(scope="module")
def block():
    """The six IGN tiles joined, and its Epoch (saliency computed once for the module)."""
    need_data(IGN)
    cloud = read_epoch(IGN)
    return cloud, compute_epoch(cloud)


@pytest.fixture(scope="module")
def edited(block):
    """The edited copy of the block (benchmarks/edited_epoch.py) as an Epoch, and its edits."""
    from edited_epoch import edit

    two, edits = edit(block[0])
    return compute_epoch(two), edits


def significant_share(cm):
    n = int(cm.table["valid"].sum())
    return cm.n_significant / n, n


def test_two_disjoint_halves_of_the_block_give_few_significant_cells(block):
    from change_noise import halves

    share, n = significant_share(changes(*halves(block[0], seed=0)))
    assert n >= 20 and share <= 0.05


def test_the_block_against_60_percent_of_itself_noisy_and_moved_gives_few_significant_cells(block):
    from change_noise import thinned_noisy

    # a rate, over three draws (one draw of 24 cells flags 2 by chance one time in three at 5%)
    flagged = compared = 0
    for seed in range(3):
        _, other = thinned_noisy(block[0], seed=seed)
        cm = changes(block[1], other)
        share, n = significant_share(cm)
        flagged, compared = flagged + cm.n_significant, compared + n
        assert n >= 20
        assert np.exp(cm.levels["emd_info"].beta) > 2  # the noise raises d_EMD-Info everywhere: a survey factor
    assert flagged / compared <= 0.05


def test_the_edited_cells_are_significant_and_rank_first(block, edited):
    two, edits = edited
    cm = changes(block[1], two, cell=25)
    cells = {int(cm.grid.cell_of(np.array([xy]))[0]) for xy in edits.values()}
    assert len(cells) == 3 and cm.table["valid"][list(cells)].all()
    assert cm.score == "kl" and cm.table["significant"][list(cells)].all()
    assert set(cm.ranked(3).tolist()) == cells
    others = cm.table["valid"].copy()
    others[list(cells)] = False
    assert others.sum() >= 15 and cm.table["significant"][others].mean() <= 0.05


def test_a_sparse_pair_of_two_class_schemes_gives_a_map_without_options(block):
    from change_noise import sparse_pair

    a, b = sparse_pair(block[0])
    with pytest.warns(LidarSigWarning, match="classified differently.*ranked by delta_FV"):
        cm = changes(a, b)
    assert cm.cell_rule == cm.min_points_rule == "auto" and max(cm.density) < 0.4
    assert cm.table["valid"].sum() >= 20 and cm.score == "fv"  # delta_FV does not depend on the labels
    assert cm.n_significant / cm.table["valid"].sum() <= 0.05  # two thinnings of the same land
    with pytest.warns(LidarSigWarning) as said:  # the schemes made comparable: only the density is said
        merged = changes(a, b, class_map="1,3,4,5=vegetation-or-other")
    assert [str(w.message) for w in said] == merged.warnings and len(merged.warnings) == 1
    assert merged.score == "kl" and "below 1 point/m²" in merged.warnings[0]
    assert np.exp(merged.levels["kl"].beta) < 0.1 * np.exp(cm.levels["kl"].beta)  # the scheme no longer


def test_a_series_of_three_epochs_puts_each_edit_in_its_interval(block, edited, tmp_path):
    pytest.importorskip("rasterio", reason="rasterio not installed: pip install -e '.[geo]'")
    import rasterio
    from edited_epoch import edit

    two, first = edited
    three, second = edit(two.cloud, seed=14, avoid=list(first.values()), name="second edit")
    series = changes(block[1], two, three)
    series.save(tmp_path / "series.tif")
    with rasterio.open(tmp_path / "series.tif") as src:
        assert src.descriptions[-1].startswith("when:")
        when = src.read(src.count)
    grid = series.grid
    for interval, edits in ((1, first), (2, second)):
        for name, xy in edits.items():
            row, col = divmod(int(grid.cell_of(np.array([xy]))[0]), grid.cols)
            assert when[row, col] == interval, (interval, name)
    compared = when != -9999.0
    assert (when[compared] > 0).sum() <= 6 + 0.05 * compared.sum()  # the edits, and few others


def test_resampling_draws_per_cell_so_that_results_do_not_depend_on_the_processing_order():
    from conftest import airborne_like
    from lidar_sig.change_map import Grid, bin_points, compute_epoch, null_metrics
    from lidar_sig.change_map._cells import cell_table
    from lidar_sig.method.classes import ASPRS
    from lidar_sig.method.cloud import PointCloud

    epochs = [compute_epoch(PointCloud(airborne_like(6000, seed=s)[0], airborne_like(6000, seed=s)[1]))
              for s in (0, 1)]
    grid = Grid.covering(np.vstack([e.cloud.xyz[:, :2] for e in epochs]), 10.0)
    binned = [bin_points(e, grid, ASPRS, True) for e in epochs]
    table = cell_table(grid, binned, 100)
    full = null_metrics(table, binned, ASPRS)
    valid = np.flatnonzero(table["valid"])
    assert len(valid) >= 8 and np.isfinite(full[valid]).all()
    part = table.copy()
    part["valid"][valid[::2]] = False  # half the cells, processed without the others
    half = null_metrics(part, binned, ASPRS)
    assert np.array_equal(half[valid[1::2]], full[valid[1::2]])  # same draws, exactly
    other = null_metrics(table, binned, ASPRS, seed=18)
    assert not np.array_equal(other[valid], full[valid])
