"""Compiled kernels (numba): per neighbour, shared by the descriptors; per point, the saliency
and Egeom of :mod:`lidar_sig.method.saliency_map`. Importing this module loads numba: the modules that use
it import it where they compute, so that listing commands or reading an archive does not.

Each per-neighbour kernel walks the distance-sorted neighbour list of a query point once, keeps
running sums, and reads off every scale when the walk reaches that scale's neighbour count
(docs/method.md, "Neighbourhoods and scales": smaller scales are prefixes of the largest). Work
is spread over the cores with ``prange``.
"""
import numpy as np
from numba import njit, prange


@njit(cache=True, inline="always")
def descending3(a, b, c):
    """Three values sorted descending: three compare-exchanges."""
    if a < b:
        a, b = b, a
    if b < c:
        b, c = c, b
    if a < b:
        a, b = b, a
    return a, b, c


@njit(cache=True, inline="always")
def _rotate(app, aqq, apq, arp, arq):
    # One Jacobi rotation zeroing a_pq; r is the third index (Numerical Recipes, 11.1).
    if apq == 0.0:
        return app, aqq, arp, arq
    theta = (aqq - app) / (2.0 * apq)
    t = 1.0 / (abs(theta) + np.sqrt(theta * theta + 1.0))
    if theta < 0.0:
        t = -t
    c = 1.0 / np.sqrt(t * t + 1.0)
    s = t * c
    return app - t * apq, aqq + t * apq, c * arp - s * arq, s * arp + c * arq


@njit(cache=True)
def _eigvalsh3_jacobi(a00, a11, a22, a01, a02, a12):
    # cyclic Jacobi: slower, but keeps full relative accuracy for close eigenvalues
    for _ in range(16):
        off = a01 * a01 + a02 * a02 + a12 * a12
        if off <= 1e-34 * (a00 * a00 + a11 * a11 + a22 * a22 + off):
            break
        a00, a11, a02, a12 = _rotate(a00, a11, a01, a02, a12)
        a01 = 0.0
        a00, a22, a01, a12 = _rotate(a00, a22, a02, a01, a12)
        a02 = 0.0
        a11, a22, a01, a02 = _rotate(a11, a22, a12, a01, a02)
        a12 = 0.0
    return descending3(a00, a11, a22)


# Relative eigenvalue gap under which the closed form hands over to Jacobi: there the
# trigonometric solution loses about half the digits (acos near +-1).
_CLOSE_GAP = 1e-3


@njit(cache=True)
def eigvalsh3(a00, a11, a22, a01, a02, a12):
    """Eigenvalues of a symmetric 3x3 matrix, sorted descending.

    Closed form (trigonometric solution of the characteristic cubic) for well separated
    eigenvalues; cyclic Jacobi when two of them are within ``_CLOSE_GAP`` of the spread, as the
    two in-plane eigenvalues of a regularly sampled plane are. Accurate to about 1e-12 of the
    largest eigenvalue either way.
    """
    p1 = a01 * a01 + a02 * a02 + a12 * a12
    q = (a00 + a11 + a22) / 3.0
    b00, b11, b22 = a00 - q, a11 - q, a22 - q
    p2 = b00 * b00 + b11 * b11 + b22 * b22 + 2.0 * p1
    if p2 <= 0.0:
        return q, q, q
    p = np.sqrt(p2 / 6.0)
    inv = 1.0 / p
    c00, c11, c22, c01, c02, c12 = b00 * inv, b11 * inv, b22 * inv, a01 * inv, a02 * inv, a12 * inv
    r = 0.5 * (c00 * (c11 * c22 - c12 * c12) - c01 * (c01 * c22 - c12 * c02)
               + c02 * (c01 * c12 - c11 * c02))
    r = min(1.0, max(-1.0, r))
    phi = np.arccos(r) / 3.0
    e0 = q + 2.0 * p * np.cos(phi)
    e2 = q + 2.0 * p * np.cos(phi + 2.0 * np.pi / 3.0)
    e1 = 3.0 * q - e0 - e2
    if min(e0 - e1, e1 - e2) < _CLOSE_GAP * (e0 - e2):
        return _eigvalsh3_jacobi(a00, a11, a22, a01, a02, a12)
    return e0, e1, e2


@njit(cache=True, parallel=True)
def covariance_eigenvalues(xyz, rows, idx, counts, weights):
    """Eigenvalues (B, S, 3) of the covariance tensor (C3DCM) at every scale.

    T = sum w_q (q - qbar)(q - qbar)^T / sum w_q over the first ``counts[b, s]`` neighbours,
    qbar the weighted centroid; ``weights`` (N,) are the neighbours' weights, or empty for
    equal ones (the paper's T = (1/n) sum (q - qbar)(q - qbar)^T). From running sums of offsets
    to the query point (small numbers, so no cancellation against UTM-sized coordinates).
    Negative round-off is clamped to 0; count 0 gives NaN.
    """
    B = idx.shape[0]
    S = counts.shape[1]
    weighted = weights.size > 0
    out = np.empty((B, S, 3))
    for b in prange(B):
        i = rows[b]
        cx, cy, cz = xyz[i, 0], xyz[i, 1], xyz[i, 2]
        sw = sx = sy = sz = sxx = syy = szz = sxy = sxz = syz = 0.0
        n = 0
        for s in range(S):
            target = counts[b, s]
            while n < target:
                j = np.uint64(idx[b, n])  # unsigned: no wrap-around check per access (grid._U)
                w = weights[j] if weighted else 1.0
                dx = xyz[j, 0] - cx
                dy = xyz[j, 1] - cy
                dz = xyz[j, 2] - cz
                wx, wy, wz = w * dx, w * dy, w * dz
                sw += w
                sx += wx
                sy += wy
                sz += wz
                sxx += wx * dx
                syy += wy * dy
                szz += wz * dz
                sxy += wx * dy
                sxz += wx * dz
                syz += wy * dz
                n += 1
            if target == 0 or not sw > 0.0:
                out[b, s, 0] = out[b, s, 1] = out[b, s, 2] = np.nan
                continue
            f = 1.0 / sw
            mx, my, mz = sx * f, sy * f, sz * f
            l0, l1, l2 = eigvalsh3(sxx * f - mx * mx, syy * f - my * my, szz * f - mz * mz,
                                   sxy * f - mx * my, sxz * f - mx * mz, syz * f - my * mz)
            out[b, s, 0] = max(l0, 0.0)
            out[b, s, 1] = max(l1, 0.0)
            out[b, s, 2] = max(l2, 0.0)
    return out


@njit(cache=True, parallel=True)
def voting_eigenvalues(xyz, rows, idx, counts, sigma, weights):
    """Eigenvalues (B, S, 3), descending, of the ball-voting tensor (T3DVT) at every scale.

    T = sum_q mu (I - u u^T) / sum_q mu over the neighbours q != x_i (zero-length offsets
    skipped), u = (q - x_i)/d, mu = w_q exp(-d^2 / sigma^2) with sigma the scale's radius
    (docs/descriptors.md, "T3DVT") and w_q the neighbour's weight (``weights``, or 1 when empty).
    T is accumulated as I - M / W with W = sum mu, M = sum (mu / d^2) v v^T, so eig(T) =
    1 - eig(M / W). NaN where the scale is undefined (count 0) or no vote was cast.
    """
    B = idx.shape[0]
    S = counts.shape[1]
    weighted = weights.size > 0
    out = np.empty((B, S, 3))
    for b in prange(B):
        i = rows[b]
        cx, cy, cz = xyz[i, 0], xyz[i, 1], xyz[i, 2]
        for s in range(S):
            # one tight loop per scale with scalar sums (the weights depend on the scale)
            inv_s2 = 1.0 / (sigma[b, s] * sigma[b, s]) if sigma[b, s] > 0.0 else 0.0
            wsum = mxx = myy = mzz = mxy = mxz = myz = 0.0
            for p in range(counts[b, s]):
                j = np.uint64(idx[b, p])
                dx = xyz[j, 0] - cx
                dy = xyz[j, 1] - cy
                dz = xyz[j, 2] - cz
                d2 = dx * dx + dy * dy + dz * dz
                if d2 == 0.0:
                    continue
                mu = np.exp(-d2 * inv_s2)
                if weighted:
                    mu *= weights[j]
                w = mu / d2
                wsum += mu
                mxx += w * dx * dx
                myy += w * dy * dy
                mzz += w * dz * dz
                mxy += w * dx * dy
                mxz += w * dx * dz
                myz += w * dy * dz
            if counts[b, s] == 0 or not wsum > 0.0:
                out[b, s, 0] = out[b, s, 1] = out[b, s, 2] = np.nan
                continue
            f = 1.0 / wsum
            l0, l1, l2 = eigvalsh3(mxx * f, myy * f, mzz * f, mxy * f, mxz * f, myz * f)
            # eigenvalues of T = I - M/W, descending, clamped to [0, 1]
            out[b, s, 0] = min(1.0, max(0.0, 1.0 - l2))
            out[b, s, 1] = min(1.0, max(0.0, 1.0 - l1))
            out[b, s, 2] = min(1.0, max(0.0, 1.0 - l0))
    return out


@njit(cache=True)
def order_eigenvalues(ev, out, round_off):
    """Each row of ``ev`` (M, 3) sorted descending into ``out``, values in
    [-round_off x the row's largest magnitude, 0) set to 0; rows holding NaN copied as they
    are. Returns the index of the first row with a value below that bound (clearly negative),
    -1 when there is none (:func:`lidar_sig.plugins._kinds.descending`). One pass, no
    temporaries: it runs on every block's (B, S, 3) eigenvalues."""
    for i in range(ev.shape[0]):
        a, b, c = ev[i, 0], ev[i, 1], ev[i, 2]
        if a != a or b != b or c != c:
            out[i, 0], out[i, 1], out[i, 2] = a, b, c
            continue
        a, b, c = descending3(a, b, c)
        bound = -round_off * max(abs(a), abs(c))
        if c < bound:
            return i
        out[i, 0], out[i, 1], out[i, 2] = max(a, 0.0), max(b, 0.0), max(c, 0.0)
    return -1


@njit(cache=True, parallel=True)
def saliency_rows(ev, out):
    """(Cl, Cs, Cp) of each row of sorted eigenvalues ``ev`` (M, 3) into ``out`` (M, 3); NaN
    where their sum is not positive (docs/method.md, "Saliency map";
    :func:`lidar_sig.method.saliency_map.saliency_from_eigenvalues`)."""
    for i in prange(ev.shape[0]):
        l0, l1, l2 = ev[i, 0], ev[i, 1], ev[i, 2]
        total = l0 + l1 + l2
        if total > 0.0:  # False for NaN too
            out[i, 0] = (l0 - l1) / total
            out[i, 1] = 2.0 * (l1 - l2) / total
            out[i, 2] = 3.0 * l2 / total
        else:
            out[i, 0] = out[i, 1] = out[i, 2] = np.nan


@njit(cache=True, parallel=True)
def entropy_rows(sal, out, upper):
    """Egeom of each saliency row of ``sal`` (M, 3) into ``out`` (M,), clipped to [0, ``upper``]
    (ln 3) against round-off; NaN rows stay NaN (docs/method.md, "Saliency map";
    :func:`lidar_sig.method.saliency_map.geometric_entropy`)."""
    for i in prange(sal.shape[0]):
        e = 0.0
        for j in range(3):
            c = sal[i, j]
            if c > 0.0:
                e -= c * np.log(c)
            elif c != c:  # NaN
                e = np.nan
                break
        out[i] = min(max(e, 0.0), upper) if e == e else e


@njit(cache=True, parallel=True, error_model="numpy")
def mean_over_scales(per_scale, out):
    """Mean of ``per_scale`` (M, S, C) over the scales where a value is defined into ``out``
    (M, C); NaN where none is (docs/method.md, "Strategies", Multiscale). numpy.nanmean's sum and count, in its order
    (undefined values as +0.0, scales in turn), without its four temporary copies."""
    for i in prange(per_scale.shape[0]):
        for c in range(per_scale.shape[2]):
            total = 0.0
            count = 0
            for s in range(per_scale.shape[1]):
                v = per_scale[i, s, c]
                defined = v == v
                term = v if defined else 0.0
                total = term if s == 0 else total + term
                count += defined
            out[i, c] = total / count  # 0 / 0: the NaN numpy.nanmean gives, to the bit
