"""The area-weight cap above a million points, from a sample of windows (docs/method.md,
"Neighbour weights"): the same in one block and in any tiling, close to the median of every location, and
a run in tiles searches only the sample's windows before its tiles."""
import numpy as np
import pytest

import lidar_sig as ls
from lidar_sig.base.errors import LidarSigWarning
from lidar_sig.numerics import neighbors
from lidar_sig.numerics.neighbors import CAP_WINDOW, cap_share, in_cap_windows
from lidar_sig.pipeline import flow
from lidar_sig.tiling._core import saliency_in_tiles
from lidar_sig.tiling.run_set import run_set

from conftest import SAMPLES
from test_tiling import assert_same_saliency

EPOCH = SAMPLES / "epoch1.laz"  # 41,507 points over 64 m x 64 m


class CapsFound(list):
    """The caps one-block runs found; ``taken``: per run, (locations in the sample, locations)
    or None when every location gave it."""


@pytest.fixture
def sampled_cap(monkeypatch):
    """The sample's rule on the small epoch: a share of 0.36 of the 10 m windows, and the caps
    the one-block runs find, recorded."""
    monkeypatch.setattr(neighbors, "CAP_POINTS", 15_000)
    found = CapsFound()

    def recorded(second, sampled=None):
        found.append(neighbors.set_area_cap(second, sampled))
        taken.append(None if sampled is None else (int(sampled.sum()), len(sampled)))
        return found[-1]

    taken = found.taken = []

    monkeypatch.setattr(flow, "set_area_cap", recorded)
    return found


def test_the_sampled_cap_is_that_of_one_block_in_any_tiling_and_tiles_keep_no_distances(tmp_path, sampled_cap):
    pipe = ls.Pipeline(progress=False)
    cloud = ls.read(EPOCH)
    assert cap_share(len(cloud)) < 1.0
    single, _ = pipe.saliency(cloud)
    (cap,) = sampled_cap
    for side in (25.0, 13.0):
        run = run_set(pipe, [EPOCH], work=tmp_path / f"w{side:g}", tile_size=side)
        assert run.ctx.area_cap == cap
        assert not run.plan.second_known  # each tile searched its own points' distances
        assert not (tmp_path / f"w{side:g}" / "second").exists() or not any((tmp_path / f"w{side:g}" / "second").iterdir())
        assert_same_saliency(run.saliency_of(run.sources[0]), single)
    in_memory, _ = saliency_in_tiles(pipe, cloud, 20.0)
    assert_same_saliency(in_memory, single)


def test_the_sampled_cap_does_not_move_with_the_points_order_and_is_near_every_location_s(monkeypatch, sampled_cap):
    pipe = ls.Pipeline(progress=False)
    cloud = ls.read(EPOCH)
    order = np.random.default_rng(0).permutation(len(cloud))
    pipe.saliency(cloud)
    pipe.saliency(ls.PointCloud(cloud.xyz[order], cloud.labels[order], crs=cloud.crs, units=cloud.units))
    assert sampled_cap[0] == sampled_cap[1]
    monkeypatch.setattr(neighbors, "CAP_POINTS", 10**9)  # every location
    pipe.saliency(cloud)
    every = sampled_cap[2]
    (inside, locations), _, everywhere = sampled_cap.taken
    assert 0 < inside < locations and everywhere is None  # the sample was taken, then every location
    assert abs(sampled_cap[0] / every - 1.0) < 0.1


def test_the_windows_picked_are_the_share_asked_and_the_reach_holds_every_point_near_them():
    rng = np.random.default_rng(1)
    xy = rng.uniform(0.0, 200 * CAP_WINDOW, (200_000, 2)) + [650_000.0, 6_860_000.0]
    picked = in_cap_windows(xy, 0.05)
    windows = np.unique(np.floor(xy / CAP_WINDOW).astype(np.int64), axis=0)
    share = in_cap_windows((windows + 0.5) * CAP_WINDOW, 0.05).mean()
    assert abs(share - 0.05) < 0.01  # 40,000 windows: a standard error of 0.001
    near = in_cap_windows(xy, 0.05, 3.0)
    assert near[picked].all()
    # a point is near when one within 3 m of it lies in a picked window
    for offset in ([3.0, 0.0], [-3.0, 0.0], [0.0, 3.0], [0.0, -3.0]):
        assert near[in_cap_windows(xy + offset, 0.05)].all()
    assert in_cap_windows(xy, 1.0).all()


def test_a_resumed_run_takes_the_saved_cap_only_under_the_same_rule(tmp_path, sampled_cap, monkeypatch):
    pipe = ls.Pipeline(progress=False)
    work = tmp_path / "work"
    first = run_set(pipe, [EPOCH], work=work, tile_size=25.0)
    with pytest.warns(LidarSigWarning, match="resumed from"):
        again = run_set(pipe, [EPOCH], work=work, tile_size=25.0, resume=True)
    assert again.ctx.area_cap == first.ctx.area_cap and not again.plan.second_known  # as the pass left it
    assert_same_saliency(again.saliency_of(again.sources[0]), first.saliency_of(first.sources[0]))
    monkeypatch.setattr(neighbors, "CAP_POINTS", 10**9)  # another rule: the saved cap is not its
    with pytest.warns(LidarSigWarning, match="resumed from"):
        other = run_set(pipe, [EPOCH], work=work, tile_size=25.0, resume=True)
    assert other.plan.second_known  # every location's pass ran again
