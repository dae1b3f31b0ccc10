"""The change map's height component delta_H (issue 33): heights above each cell's own lowest
points compared as an earth mover's distance in metres; registration free (a vertical offset
cancels), unchanged by a rotation about the vertical, a translation or the CRS unit, and what
finds earth moved where the signature's metrics do not."""
import warnings

import numpy as np
import pytest

from conftest import airborne_like
from lidar_sig.change_map import changes
from lidar_sig.change_map._heights import LOWEST, height_distance, height_profile
from lidar_sig.method.cloud import PointCloud
from lidar_sig.method.crs import Units
from lidar_sig.base.errors import LidarSigWarning

FOOT = 0.3048


def test_delta_h_is_the_earth_movers_distance_of_heights_above_the_lowest_points():
    rng = np.random.default_rng(0)
    z = rng.uniform(0.0, 10.0, 5000)
    assert height_distance(z, z) == 0.0
    assert height_distance(z, z + 37.5) == pytest.approx(0.0, abs=1e-9)  # a vertical offset cancels
    # flat ground, then half of it raised by 2 m: the quantile functions differ by 2 m over half
    # the levels, and the lowest points stay where they were
    flat = rng.normal(0.0, 0.01, 5000)
    raised = np.where(np.arange(5000) % 2 == 0, flat, flat + 2.0)
    assert height_distance(flat, raised) == pytest.approx(1.0, abs=0.03)
    # the reference is a low quantile, not the lowest point: one deep outlier barely moves it
    assert height_distance(z, np.append(z, -50.0)) < 0.05
    assert height_profile(z)[int(100 * LOWEST)] == pytest.approx(0.0, abs=0.1)  # heights above the 2% quantile
    assert height_distance(flat * FOOT, raised * FOOT) == pytest.approx(FOOT * height_distance(flat, raised))


def two_epochs(transform=lambda xyz: xyz, units=Units(), raise_west=5):
    """Two airborne-like epochs of the same scene, the second with the ground of the west half of
    two 10 m cells raised by 2 m, through ``transform``."""
    xyz_a, labels_a = airborne_like(8000, seed=1)
    xyz_b, labels_b = airborne_like(8000, seed=2)
    moved = (labels_b == 2) & (xyz_b[:, 0] < raise_west) & (xyz_b[:, 1] > 20)
    xyz_b[moved, 2] += 2.0
    offset = np.array([770_000.0, 6_277_000.0, 0.0])
    out = []
    for xyz, labels in ((xyz_a, labels_a), (xyz_b, labels_b)):
        inside = np.all(np.mod(xyz[:, :2], 10.0) != 0, axis=1)  # none on a cell edge, which a turn makes open
        out.append(PointCloud(transform(xyz[inside] + offset), labels[inside], crs=None, units=units))
    return out


def delta_h(a, b):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", LidarSigWarning)  # few cells: sampling noise only
        cm = changes(a, b, cell=10, min_points=80)
    t = cm.table
    return {(round(float(x), 3), round(float(y), 3)): h
            for x, y, h, v in zip(t["x_min"], t["y_min"], t["height"], t["valid"]) if v}, cm


def test_earth_moved_is_seen_by_delta_h_and_not_by_the_class_shares():
    _, cm = delta_h(*two_epochs())
    t = cm.table
    ground = cm.class_table.class_names.index("ground")
    only_ground = t["valid"] & (cm.classes_a.sum(axis=1) == cm.classes_a[:, ground]) & (
        cm.classes_b.sum(axis=1) == cm.classes_b[:, ground])
    moved = only_ground & (t["x_max"] <= 770_010.0) & (t["y_min"] >= 6_277_020.0)  # half raised
    assert moved.sum() == 2 and (only_ground & ~moved).sum() >= 4
    assert (t["height"][moved] > 0.6).all() and (t["height"][only_ground & ~moved] < 0.2).all()
    assert (t["kl"][moved] < 0.05).all()  # the same class in the same share: the signature cannot say
    # a cell raised as a whole keeps its heights above its own lowest points: not seen
    _, whole = delta_h(*two_epochs(lambda xyz: xyz, raise_west=10))
    assert whole.table["height"][np.flatnonzero(moved)].max() < 0.2


def test_delta_h_does_not_change_with_a_rotation_about_the_vertical_a_translation_or_the_unit():
    reference, _ = delta_h(*two_epochs())
    origin = np.array([770_000.0, 6_277_000.0])

    def turned(xyz):  # 90 degrees about a grid node: cells onto cells
        xy = xyz[:, :2] - origin
        return np.column_stack([origin + np.column_stack([-xy[:, 1], xy[:, 0]]), xyz[:, 2] + 100.0])

    rotated, _ = delta_h(*two_epochs(turned))
    back = {(round(origin[0] + (y - origin[1]), 3), round(origin[1] - (x + 10 - origin[0]), 3)): h
            for (x, y), h in rotated.items()}  # the lower-left corner of each turned cell, turned back
    assert set(back) == set(reference)
    assert all(back[k] == pytest.approx(reference[k], rel=1e-9, abs=1e-12) for k in reference)
    moved, _ = delta_h(*two_epochs(lambda xyz: xyz + np.array([1000.0, -2000.0, 55.0])))
    assert sorted(moved.values()) == pytest.approx(sorted(reference.values()), rel=1e-9, abs=1e-12)
    feet, cm = delta_h(*two_epochs(lambda xyz: xyz / FOOT, Units(FOOT, FOOT, "US survey foot", True)))
    assert cm.cell == 10 and len(feet) == len(reference)
    assert sorted(feet.values()) == pytest.approx(sorted(reference.values()), rel=1e-9, abs=1e-12)
