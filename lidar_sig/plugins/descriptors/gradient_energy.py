"""The 2D gradient energy tensor (GET) of the height field z(x, y) (docs/descriptors.md, "T3DVT-GET", T3DVT-GET).

Derivatives come from a least-squares operator over cylindrical neighbourhoods, applied three
times: to z (first derivatives), to those (second) and to those again (third). Then
GET = H H - (g t^T + t g^T) / 2 (Felsberg & Koethe 2005), with H the Hessian (f_xy and f_yx
averaged: equal in theory, they differ only through the discrete operator), g the gradient and
t = (f_xxx + f_xyy, f_xxy + f_yyy). The mixed third derivatives are taken as f_xyy = d/dx f_yy
and f_xxy = d/dy f_xx (equal to the other orders in theory), which makes t exactly the gradient
of the discrete Laplacian f_xx + f_yy: the operator is covariant under rotations of the plane,
so GET's eigenvalues, and T3DVT-GET, are invariant to rotations about z.

Each pass needs the previous pass at the neighbours, so the cloud is processed as a wavefront
over blocks of points sorted by voxel: a block's pass 2 runs as soon as pass 1 is done for every
point its neighbourhoods reach, and its neighbour lists are dropped after pass 3. Memory stays
bounded by a few blocks of neighbour lists plus six derivatives and cl_GET per point and scale.
"""
from __future__ import annotations

from typing import TYPE_CHECKING, TypeAlias

import numpy as np
from numba import njit, prange
from numpy.typing import NDArray

from ...base.progress import progress as _progress

if TYPE_CHECKING:
    from ...numerics.neighbors import NeighborhoodBatch, NeighborIndex

#: The arrays the kernels take: float64 values, int64 rows and counts, int32 neighbour lists.
Floats: TypeAlias = NDArray[np.float64]
Ints: TypeAlias = NDArray[np.int64]
Neighbours: TypeAlias = NDArray[np.int32]

# Relative size of the operator's determinant under which the neighbourhood is collinear.
_DEGENERATE = 1e-12


@njit(cache=True, inline="always")
def _operator(rxx: float, ryy: float, rxy: float) -> tuple[float, float, float]:
    # (A, B, C) = (ryy, rxy, rxx) / Dt, or NaN for a collinear or empty neighbourhood
    dt = rxx * ryy - rxy * rxy
    if not dt > _DEGENERATE * (rxx + ryy) * (rxx + ryy):
        return np.nan, np.nan, np.nan
    return ryy / dt, rxy / dt, rxx / dt


@njit(cache=True, parallel=True)
def first_pass(xy: Floats, z: Floats, rows: Ints, ptr: Ints, nbr: Neighbours, counts: Ints, out: Floats) -> None:
    """(f_x, f_y) of z at each row and scale into out[row, s, 0:2] (docs/descriptors.md, "T3DVT-GET", step 1).

    f_x = sum (dx ryy - dy rxy) / Dt (f_h - f_i), f_y = sum (dy rxx - dx rxy) / Dt (f_h - f_i).
    """
    S = counts.shape[1]
    for b in prange(rows.size):
        i = rows[b]
        xi, yi, zi = xy[i, 0], xy[i, 1], z[i]
        for s in range(S):
            rxx = ryy = rxy = gx = gy = 0.0
            for p in range(ptr[b], ptr[b] + counts[b, s]):
                j = nbr[p]
                dx = xy[j, 0] - xi
                dy = xy[j, 1] - yi
                df = z[j] - zi
                rxx += dx * dx
                ryy += dy * dy
                rxy += dx * dy
                gx += dx * df
                gy += dy * df
            a, bb, c = _operator(rxx, ryy, rxy)
            out[i, s, 0] = a * gx - bb * gy
            out[i, s, 1] = c * gy - bb * gx


@njit(cache=True, parallel=True)
def second_pass(xy: Floats, rows: Ints, ptr: Ints, nbr: Neighbours, counts: Ints, d1: Floats, out: Floats) -> None:
    """(f_xx, f_xy, f_yx, f_yy) into out[row, s, 0:4] from the first derivatives d1."""
    S = counts.shape[1]
    for b in prange(rows.size):
        i = rows[b]
        xi, yi = xy[i, 0], xy[i, 1]
        for s in range(S):
            fxi, fyi = d1[i, s, 0], d1[i, s, 1]
            rxx = ryy = rxy = ax = ay = bx = by = 0.0
            for p in range(ptr[b], ptr[b] + counts[b, s]):
                j = nbr[p]
                dx = xy[j, 0] - xi
                dy = xy[j, 1] - yi
                u = d1[j, s, 0] - fxi
                v = d1[j, s, 1] - fyi
                rxx += dx * dx
                ryy += dy * dy
                rxy += dx * dy
                ax += dx * u
                ay += dy * u
                bx += dx * v
                by += dy * v
            a, bb, c = _operator(rxx, ryy, rxy)
            out[i, s, 0] = a * ax - bb * ay  # f_xx
            out[i, s, 1] = c * ay - bb * ax  # f_xy
            out[i, s, 2] = a * bx - bb * by  # f_yx
            out[i, s, 3] = c * by - bb * bx  # f_yy


@njit(cache=True)
def get_line_saliency(gx: float, gy: float, hxx: float, hxy: float, hyy: float, tx: float, ty: float,
                      magnitude_scale: float, threshold: float) -> float:
    """cl_GET of one GET (docs/descriptors.md, "T3DVT-GET", steps 2-3), NaN where undefined.

    GET = H H - (g t^T + t g^T)/2; with eigenvalues m0 >= m1: if m0 > 0, m1 = max(m1, 0) and
    cl_GET = (m0 - m1)/(m0 + m1). Undefined where m0 <= 0 or m0 * magnitude_scale < threshold.
    """
    g00 = hxx * hxx + hxy * hxy - gx * tx
    g11 = hxy * hxy + hyy * hyy - gy * ty
    g01 = hxy * (hxx + hyy) - 0.5 * (gx * ty + tx * gy)
    half_tr = 0.5 * (g00 + g11)
    rad: float = np.sqrt(0.25 * (g00 - g11) * (g00 - g11) + g01 * g01)
    m0 = half_tr + rad
    if not (m0 > 0.0 and m0 * magnitude_scale >= threshold):
        return np.nan
    m1 = max(half_tr - rad, 0.0)
    return (m0 - m1) / (m0 + m1)


@njit(cache=True, parallel=True)
def third_pass(xy: Floats, rows: Ints, ptr: Ints, nbr: Neighbours, counts: Ints, sigma: Floats, d1: Floats,
               d2: Floats, threshold: float, out: Floats) -> None:
    """Third derivatives, GET and cl_GET per scale into out[row, s] (NaN where undefined).
    GET's magnitude is made dimensionless by sigma^2.

    t = grad(f_xx + f_yy): f_xxx, f_xxy from f_xx and f_xyy (as d/dx f_yy), f_yyy from f_yy.
    """
    S = counts.shape[1]
    for b in prange(rows.size):
        i = rows[b]
        xi, yi = xy[i, 0], xy[i, 1]
        for s in range(S):
            fxxi, fyyi = d2[i, s, 0], d2[i, s, 3]
            rxx = ryy = rxy = ax = ay = cx = cy = 0.0
            for p in range(ptr[b], ptr[b] + counts[b, s]):
                j = nbr[p]
                dx = xy[j, 0] - xi
                dy = xy[j, 1] - yi
                u = d2[j, s, 0] - fxxi
                w = d2[j, s, 3] - fyyi
                rxx += dx * dx
                ryy += dy * dy
                rxy += dx * dy
                ax += dx * u
                ay += dy * u
                cx += dx * w
                cy += dy * w
            a, bb, c = _operator(rxx, ryy, rxy)
            fxxx = a * ax - bb * ay
            fxxy = c * ay - bb * ax
            fxyy = a * cx - bb * cy  # d/dx f_yy
            fyyy = c * cy - bb * cx
            hxy = 0.5 * (d2[i, s, 1] + d2[i, s, 2])
            out[i, s] = get_line_saliency(d1[i, s, 0], d1[i, s, 1], d2[i, s, 0], hxy, d2[i, s, 3],
                                          fxxx + fxyy, fxxy + fyyy, sigma[b, s] * sigma[b, s], threshold)


@njit(cache=True)
def _pack_rows(idx: Ints, n: Ints, out: Neighbours) -> None:
    # concatenate the first n[b] entries of every row
    pos = 0
    for b in range(idx.shape[0]):
        for p in range(n[b]):
            out[pos] = idx[b, p]
            pos += 1


class _Block:
    """A block of query rows with its neighbour lists, waiting for passes 2 and 3."""

    def __init__(self, rows: Ints, batch: NeighborhoodBatch) -> None:
        self.rows = rows
        self.ptr = np.zeros(len(rows) + 1, np.int64)
        np.cumsum(batch.n, out=self.ptr[1:])
        self.nbr = np.empty(int(self.ptr[-1]), np.int32)
        _pack_rows(batch.idx, batch.n, self.nbr)
        self.counts = batch.counts.copy()
        self.sigma = batch.sigma.copy()
        # farthest row (sorted order) the block's neighbourhoods reach
        self.reach = max(int(self.nbr.max()) if self.nbr.size else 0, int(rows[-1]))
        self.passes = 1


def line_saliency_of_index(index: NeighborIndex, z: Floats, *, threshold: float = 0.0,
                           progress: bool | None = False) -> Floats:
    """(n, S) cl_GET per point (the index's sorted order) and scale of a cylindrical
    NeighborIndex; NaN where GET is undefined.

    ``index`` searches (x, y, 0); ``z`` are the heights in the index's sorted order.
    """
    n, n_scales = len(index.xyz), len(index.scales)
    xy = np.ascontiguousarray(index.xyz[:, :2])
    z = np.ascontiguousarray(z, dtype=np.float64)
    d1 = np.empty((n, n_scales, 2))
    d2 = np.empty((n, n_scales, 4))
    out = np.empty((n, n_scales))
    held: list[_Block] = []
    for rows in _progress(index.blocks(), desc="gradient energy tensor", enabled=progress, unit="block"):
        block = _Block(rows, index.query(rows))
        first_pass(xy, z, rows, block.ptr, block.nbr, block.counts, d1)
        held.append(block)
        _advance(held, xy, d1, d2, out, int(rows[-1]) + 1, threshold)
    _advance(held, xy, d1, d2, out, n, threshold)
    return out


def _advance(held: list[_Block], xy: Floats, d1: Floats, d2: Floats, out: Floats, done1: int, threshold: float) -> None:
    """Run passes 2 and 3 on every held block whose neighbourhoods reach only finished rows.

    Rows [0, done1) have pass 1; rows before the first block still waiting for pass 2 have it.
    """
    while True:
        waiting = [b for b in held if b.passes == 1]
        done2 = int(waiting[0].rows[0]) if waiting else done1
        ready = next((b for b in held if (b.passes == 1 and b.reach < done1)
                      or (b.passes == 2 and b.reach < done2)), None)
        if ready is None:
            return
        if ready.passes == 1:
            second_pass(xy, ready.rows, ready.ptr, ready.nbr, ready.counts, d1, d2)
            ready.passes = 2
        else:
            third_pass(xy, ready.rows, ready.ptr, ready.nbr, ready.counts, ready.sigma, d1, d2,
                       threshold, out)
            held.remove(ready)
