"""Defaults that fit the survey: the change map's cell size and its fewest points per cell,
chosen from the epochs' point densities (``--cell auto``, ``--min-points auto``).

A signature of few points is mostly sampling noise (docs/changes.md measures it), and the level
of detection (:mod:`~lidar_sig.change_map._lod`) needs enough cells to learn what a survey
difference looks like: cells of :data:`CELL_POINTS` points or more on average, never smaller
than :data:`MIN_CELL`, and a cell compared where each epoch fills a fifth of it
(:data:`FILL`). From 50 points/m² down to 0.24 that is 25 m cells; 30 m at 0.2, 40 m at 0.1.
"""
from __future__ import annotations

import math

import numpy as np

from ..numerics.bounds import bounds, column_min

#: The value of ``cell`` and ``min_points`` that chooses them from the epochs' densities.
AUTO = "auto"
#: Side of the pixels over which an epoch's density is measured, in metres: the density is the
#: points over the area of the occupied pixels, so that water, gaps and an irregular footprint
#: do not thin it.
DENSITY_PIXEL = 10.0
#: Smallest cell side chosen, in metres (the change map's cell where the density allows it).
MIN_CELL = 25.0
#: Points an average cell holds at least: sqrt(CELL_POINTS / density) is the smallest side.
CELL_POINTS = 150
#: Chosen cell sides are multiples of this, in metres.
CELL_STEP = 5.0
#: A cell is compared where each epoch holds this share of a full cell's points (defined ones).
FILL = 0.2
#: Fewest points of a compared cell whatever the density.
MIN_POINTS_FLOOR = 30
#: Points per m² below which the change map finds fewer than 80% of known edits: in
#: benchmarks/change_power.py (two surveys, five kinds of edit, eight cells each) it found 88% at
#: 1 point/m² and 75% at 0.5 (docs/changes.md, "Power beside M3C2"). A run below it warns.
LEAST_DENSITY = 1.0
#: The recall measured just below :data:`LEAST_DENSITY` (at 0.5 points/m²), said in the warning.
RECALL_BELOW = 0.75


#: Points per m² of an epoch whose saliency a change map computes, at most: a denser epoch's
#: cells take a sample of its points (:func:`sample_fraction`; the neighbours of a sampled point
#: are still searched among all of them). A 25 m cell then holds about 3,000 points, and
#: benchmarks/change_power.py finds every edit from 2 points/m² (docs/changes.md, "The points a
#: cell's signature takes") ...
SAMPLE_DENSITY = 5.0
#: ... and points a full cell's sample holds at least (5 points/m² over 25 m cells): a smaller
#: cell given takes a denser sample (8 m cells: 48.8 points/m²).
SAMPLE_CELL_POINTS = 3125


def sample_density(rule, cell=None):
    """Points per m² an epoch's sample holds at most, by ``rule``: :data:`AUTO`, the larger of
    :data:`SAMPLE_DENSITY` and :data:`SAMPLE_CELL_POINTS` over the given ``cell``'s area (m; None:
    chosen, 25 m or more); a number, that; None, every point (None)."""
    if rule is None or rule != AUTO:
        return rule
    # a cell too small for any grid (refused later, by name) must not divide by zero here
    return SAMPLE_DENSITY if cell is None else max(SAMPLE_DENSITY, SAMPLE_CELL_POINTS / max(cell * cell, 1e-300))


def sample_fraction(points_per_m2, most=SAMPLE_DENSITY):
    """The share of an epoch's points its cells take: min(1, ``most`` / density); 1 for ``most`` None."""
    return 1.0 if most is None or points_per_m2 <= most else most / points_per_m2


def density(xy, metres_per_unit=1.0):
    """Points per m² of a cloud's (N, 2) coordinates: the points over the area of the
    :data:`DENSITY_PIXEL` pixels they occupy (``metres_per_unit`` converts the CRS unit)."""
    xy = np.asarray(xy, dtype=np.float64)
    if len(xy) == 0:
        return 0.0
    pixel = DENSITY_PIXEL / metres_per_unit
    occupied = len(occupied_pixels(np.floor((xy - column_min(xy)) / pixel).astype(np.int64)))
    return len(xy) / (occupied * DENSITY_PIXEL ** 2)


def occupied_pixels(ij):
    """The distinct pixels (i, j) of ``ij`` (N, 2) int64, as sorted keys i x 2^31 + j (0 <= j <
    2^31): a count per pixel of their box where it holds no more pixels than there are points
    (a sort of every point's pixel took 0.1 s of a change map of two 1 km² tiles), else a sort."""
    if not len(ij):
        return np.empty(0, np.int64)
    (i0, j0), (i1, j1) = bounds(ij)
    span = int(j1 - j0) + 1
    if (int(i1 - i0) + 1) * span > len(ij):
        return np.unique(ij[:, 0] * (1 << 31) + ij[:, 1])
    flat = np.flatnonzero(np.bincount((ij[:, 0] - i0) * span + (ij[:, 1] - j0)))
    return (flat // span + i0) * (1 << 31) + flat % span + j0


def auto_cell(points_per_m2):
    """Cell side in metres for a density: max(:data:`MIN_CELL`, sqrt(:data:`CELL_POINTS` /
    density) rounded up to a multiple of :data:`CELL_STEP`)."""
    side = math.sqrt(CELL_POINTS / max(points_per_m2, 1e-9))
    return max(MIN_CELL, math.ceil(side / CELL_STEP - 1e-9) * CELL_STEP)


def auto_min_points(points_per_m2, cell):
    """Fewest points with defined saliency a cell of ``cell`` metres must hold in each epoch:
    max(:data:`MIN_POINTS_FLOOR`, :data:`FILL` x density x cell²), rounded."""
    return max(MIN_POINTS_FLOOR, int(round(FILL * points_per_m2 * cell ** 2)))


def fewer_points(min_points_rule, min_points):
    """The fix when no cell holds enough points. With --min-points auto the minimum is a fifth of
    a full cell, but never below MIN_POINTS_FLOOR: where the floor holds, the cells are too small
    for a sparse survey and a larger one holds more points; above it, the cells are larger than
    what the survey fills and a smaller one needs fewer."""
    if min_points_rule == AUTO and min_points <= MIN_POINTS_FLOOR:
        return (f"use a larger cell size (--cell): the automatic minimum is {MIN_POINTS_FLOOR} points or more, "
                "which small cells of a sparse survey do not hold; or give a smaller minimum (--min-points)")
    if min_points_rule == AUTO:
        return ("use a smaller cell size (--cell): the automatic minimum is a fifth of a full cell, which cells "
                "larger than the survey do not hold; or give a smaller minimum (--min-points)")
    return "use a larger cell size (--cell) or a smaller minimum (--min-points)"


def sparse_note(names, densities):
    """The warning that the sparsest of the epochs (``names``, ``densities`` in points per m²)
    lies below :data:`LEAST_DENSITY`, where the map finds fewer changes; None above it."""
    k = min(range(len(densities)), key=densities.__getitem__)
    if densities[k] >= LEAST_DENSITY:
        return None
    return (f"{names[k]} holds {densities[k]:.2g} points/m²: below {LEAST_DENSITY:g} point/m² the change map finds "
            f"fewer than 80% of known changes ({RECALL_BELOW:.0%} at 0.5 points/m² in its benchmark, docs/changes.md), "
            "so a cell that is not significant may still have changed")


def no_defined_cell(cell, min_points, name_a, name_b, most, min_points_rule):
    """The LidarSigError of a map where no cell of ``cell`` metres holds ``min_points`` points
    with defined saliency in both epochs (``most`` the most any holds)."""
    from ..base.errors import LidarSigError, counted

    return LidarSigError(f"no cell of {cell:g} m holds {counted(min_points, 'point')} with defined saliency in both "
                         f"{name_a} and {name_b} (at most {most:,}); {fewer_points(min_points_rule, min_points)} or "
                         "larger scales")
