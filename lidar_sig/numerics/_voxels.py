"""Voxel-grid nearest-neighbour search (numba), the backend of :mod:`lidar_sig.numerics.neighbors`.

Points are sorted by voxel so that a voxel's points, and its neighbours', are close in memory;
queries in one voxel share the look-ups of the voxels around it. A query gathers every point
within a search radius t and keeps the nearest. For spherical neighbourhoods t is the radius.
For k-nearest ones t is a guess, widened until the sphere holds k points (then it holds the k
nearest): a little more than the previous query's k-th distance, the first query's the voxel
side. Consecutive queries are close (points are sorted along a curve within each voxel), so the
guess is short for about one query in ten (AHN3: 12% at k = 41, 7% at k = 101). Voxels farther
than t from the query are skipped; candidates are scanned without branches (each is written,
and kept if within t).

k-nearest rows come sorted by distance. A search for scales up to k lists the k + 1 nearest: the
one past the k-th tells whether points tied with the k-th run on, and only the rare row where
they do lists more (:func:`nearest`). Spherical rows are grouped by scale, each group in no
particular order: the neighbours of scale s are a prefix of those of scale s + 1, which is all
the descriptors need (docs/method.md, "Neighbourhoods and scales"), at O(n) instead of a sort's
O(n log n). :func:`count_within` counts the neighbours within given squared distances, :func:`count_ties` those within a factor
of each row's k-th; :mod:`lidar_sig.numerics.neighbors` decides which (the tie rule). The k-nearest
search counts its own rows' scales the same way while each row is at hand (:func:`nearest`).
"""
from __future__ import annotations

import numpy as np
from numba import get_num_threads, njit, parallel_chunksize, prange

from .bounds import column_max, column_min
from .sorting import stable_order

# Hot loops index with unsigned integers (_U): numba wraps a negative signed index around (one
# compare per access), which an unsigned index cannot need. The same arithmetic, to the bit, in
# less time (docs/performance.md).
_U = np.uint64
_ZERO = np.uint64(0)
_ONE = np.uint64(1)


@njit(cache=True)
def _select(d, ix, n, k):
    """Reorder d[:n] so that its k smallest come first (quickselect), ix follows."""
    lo, hi = 0, n - 1
    target = k - 1
    while lo < hi:
        mid = (lo + hi) // 2
        # median of three as pivot
        a, b, c = d[lo], d[mid], d[hi]
        pivot = max(min(a, b), min(max(a, b), c))
        i, j = lo, hi
        while i <= j:
            while d[i] < pivot:
                i += 1
            while d[j] > pivot:
                j -= 1
            if i <= j:
                d[i], d[j] = d[j], d[i]
                ix[i], ix[j] = ix[j], ix[i]
                i += 1
                j -= 1
        if target <= j:
            hi = j
        elif target >= i:
            lo = i
        else:
            return


@njit(cache=True, inline="always")
def _insertion_sort(d, ix, n):
    """Sort d[:n] ascending in place, ix follows: fast for a few items, or for items already
    near their places."""
    for a in range(_ONE, _U(max(n, 1))):
        v = d[a]
        w = ix[a]
        b = a  # v's place: b shifts down past every larger item before it
        while b != _ZERO and d[b - _ONE] > v:
            d[b] = d[b - _ONE]
            ix[b] = ix[b - _ONE]
            b -= _ONE
        d[b] = v
        ix[b] = w


@njit(cache=True, inline="always")
def _scatter(d, ix, m, bucket, counts, nb, out_d, out_i):
    """Counting sort's second half: d[:m] (ix following) into out by ``bucket`` (0 .. nb - 1),
    buckets in order, each in input order; ``counts[b + 1]`` holds bucket b's size on entry and
    ``counts[b]`` the end of bucket b on return."""
    for b in range(_U(nb)):
        counts[b + _ONE] += counts[b]
    for a in range(_U(m)):
        b = _U(bucket[a])
        pos = _U(counts[b])
        out_d[pos] = d[a]
        out_i[pos] = ix[a]
        counts[b] = pos + _ONE


#: Up to this many nearest, a quickselect and an insertion sort; more go through buckets.
_FEW = 16
#: A k-nearest query searches first within this many times its predecessor's k-th distance, and
#: widens the search by _KNN_WIDEN until it holds k points (docs/performance.md: chosen on AHN3
#: cropped_1 at k = 20..40 and 10..100).
_KNN_GUESS = 1.1
_KNN_WIDEN = 1.25


@njit(cache=True)
def _nearest_sorted(d, ix, m, n, span, bucket, counts, tmp_d, tmp_i, out_d, out_i):
    """The ``n`` smallest of d[:m] (each in [0, span]) into out_d[:n] ascending, out_i following.

    A bucket sort: the candidates are filed, in one branch-free pass, into 2m buckets of equal
    width in squared distance, then an insertion sort finishes the buckets that hold the n
    smallest, each item moving only within its bucket. Around a point on a surface the number
    of points grows as the squared distance, so the buckets fill about evenly and most hold one
    item or none: the insertion sort then rarely moves an item, and its branches are
    predictable (fewer buckets made the search slower: docs/performance.md).
    Any distribution is still sorted exactly (clustered distances only cost more moves). The
    work arrays hold at least m items, ``counts`` at least 2m + 1.
    """
    nb = max(1, 2 * m)
    scale = nb / span if span > 0.0 else 0.0
    counts[:nb + 1] = 0
    last = _U(nb - 1)
    for a in range(_U(m)):
        b = min(_U(np.int64(d[a] * scale)), last)  # converted signed: one instruction without AVX-512
        bucket[a] = b
        counts[b + _ONE] += 1
    _scatter(d, ix, m, bucket, counts, nb, tmp_d, tmp_i)
    end = 0  # counts[b] is now the end of bucket b: sort the buckets up to the n-th item's
    for b in range(nb):
        end = counts[b]
        if end >= n:
            break
    _insertion_sort(tmp_d, tmp_i, end)
    out_d[:n] = tmp_d[:n]
    out_i[:n] = tmp_i[:n]


@njit(cache=True)
def _partition_radius(d, ix, m, r2s, k, out_d, out_i, bucket, counts):
    """Write d[:m] (all within the largest radius) to out grouped by radius, at most the k
    nearest; return how many were written. ``bucket`` (size >= m) and ``counts`` (size S + 1)
    are work space."""
    if m > k:
        _select(d, ix, m, k)
        m = k
    n_scales = r2s.size
    counts[:] = 0
    for a in range(_U(m)):
        s = _ZERO
        for t in range(n_scales - 1):  # branch-free: radii are ascending
            s += _U(d[a] > r2s[t])
        bucket[a] = s
        counts[s + _ONE] += 1
    _scatter(d, ix, m, bucket, counts, n_scales, out_d, out_i)
    return m


@njit(cache=True, inline="always")
def _d2(pts, j, qx, qy, qz):
    """Squared distance from point j of ``pts`` to (qx, qy, qz): every search computes it so, and
    gets the same bits for the same pair."""
    dx = pts[j, 0] - qx
    dy = pts[j, 1] - qy
    dz = pts[j, 2] - qz
    return dx * dx + dy * dy + dz * dz


@njit(cache=True, inline="always")
def _box_d2(origin, h, cell_ijk, box, qx, qy, qz):
    box = _U(box)
    bx = origin[0] + cell_ijk[box, 0] * h
    by = origin[1] + cell_ijk[box, 1] * h
    bz = origin[2] + cell_ijk[box, 2] * h
    ex = max(bx - qx, max(0.0, qx - bx - h))
    ey = max(by - qy, max(0.0, qy - by - h))
    ez = max(bz - qz, max(0.0, qz - bz - h))
    return ex * ex + ey * ey + ez * ez


@njit(cache=True, inline="always")
def _face_margin(origin, h, ci, cj, ck, qx, qy, qz):
    """Distance from (qx, qy, qz) to the nearest face of its voxel (ci, cj, ck): no point outside
    Chebyshev shell s of that voxel is nearer than s voxel sides plus this."""
    lx = qx - (origin[0] + ci * h)
    ly = qy - (origin[1] + cj * h)
    lz = qz - (origin[2] + ck * h)
    return max(0.0, min(min(lx, h - lx), min(min(ly, h - ly), min(lz, h - lz))))


@njit(cache=True)
def _shell(ci, cj, ck, s, dims, cell_keys, lut, cell_start, rs, re, rc, n_ranges):
    """Append the point ranges of the occupied voxels of Chebyshev shell s; return the count."""
    nx, ny, nz = dims[0], dims[1], dims[2]
    for di in range(-s, s + 1):
        ii = ci + di
        if ii < 0 or ii >= nx:
            continue
        for dj in range(-s, s + 1):
            jj = cj + dj
            if jj < 0 or jj >= ny:
                continue
            for dk in range(-s, s + 1):
                if max(abs(di), max(abs(dj), abs(dk))) != s:
                    continue
                kk = ck + dk
                if kk < 0 or kk >= nz:
                    continue
                key = ii + nx * (jj + ny * kk)
                if lut.size > 0:
                    pos = lut[key]
                    found = pos >= 0
                else:
                    pos = np.searchsorted(cell_keys, key)
                    found = pos < cell_keys.size and cell_keys[pos] == key
                if found:
                    rs[n_ranges] = cell_start[pos]
                    re[n_ranges] = cell_start[pos + 1]
                    rc[n_ranges] = pos
                    n_ranges += 1
    return n_ranges


@njit(cache=True)
def _room_for_shell(s, rs, re, rc, n_ranges):
    """The range arrays ``rs``, ``re``, ``rc``, grown (their first ``n_ranges`` entries kept) if
    they cannot hold every voxel of Chebyshev shells 0 .. s: a query that needs far shells (an
    isolated point) pays for them, not every chunk of every search."""
    need = (2 * s + 1) ** 3
    if need <= rs.size:
        return rs, re, rc
    size = max(need, 2 * rs.size)
    grown_s, grown_e, grown_c = np.empty(size, np.int64), np.empty(size, np.int64), np.empty(size, np.int64)
    for r in range(n_ranges):
        grown_s[r] = rs[r]
        grown_e[r] = re[r]
        grown_c[r] = rc[r]
    return grown_s, grown_e, grown_c


#: Voxel ranges a search chunk has room for at first: shells 0 to 2, which settle nearly every
#: query; farther shells grow the room (:func:`_room_for_shell`).
_RANGES = 125


# This kernel stays long: the shell walk, the candidate test and the row's tie room share the
# query's running bounds and its thread's buffers in the innermost loop of every run; split into
# functions, numba would pass them through calls there (the parts it can inline already are:
# the inline="always" helpers above).
@njit(cache=True, parallel=True)
def nearest(pts, cell_of, cell_ijk, cell_start, cell_keys, lut, dims, origin, h, queries, group_start,
            ks, r2s, tie_factor, s_max, n_chunks, out_d2, out_idx, out_n, out_total, done, out_counts, out_sigma):
    """Neighbours of each query: k-nearest sorted, spherical grouped by scale (module docstring).

    k-nearest mode when ``r2s`` is empty: ``ks`` are the scales, ``ks[-1]`` the largest k (at
    most the row's room). With ``tie_factor`` > 0 a row holds the k + 1 nearest, and where the
    last of them ties with the k-th (squared distance within ``tie_factor`` times its), as many
    nearest as the row has room for: every point tied with the k-th is then listed, room
    allowing, without every query sorting that room. If ``out_counts`` has a column per scale,
    the query's scales are counted there while its row is at hand (:func:`_tie_counts`, into
    ``out_counts`` and ``out_sigma``; ``out_n`` then gets the count of the largest scale, ties
    included, and ``tie_factor`` must be > 0). Spherical mode otherwise: ``r2s`` are the
    squared radii, ascending, and ``ks[0]`` the cap.
    ``queries`` are point indices, runs of one voxel delimited by ``group_start``. Row ``i`` of
    ``out_d2`` (squared distances) and ``out_idx`` gets ``out_n[i]`` neighbours (spherical: every
    point with a squared distance of at most ``r2s[-1]``, the cap nearest of them), and in
    spherical mode ``out_total[i]`` the number within the largest radius before the cap;
    ``done[i]`` is False where ``s_max`` shells could not settle the query (the caller completes
    it).
    """
    n_groups = group_start.size - 1
    n_chunks = max(1, min(n_groups, n_chunks))
    s_cover = max(dims[0], max(dims[1], dims[2]))
    knn_mode = r2s.size == 0
    room = out_d2.shape[1]
    k = min(ks[ks.size - 1], room) if knn_mode else ks[0]
    counted = knn_mode and out_counts.shape[1] == ks.size
    k_first = min(k + 1, room) if knn_mode and tie_factor > 0.0 else k
    r2 = np.inf if knn_mode else r2s[r2s.size - 1]
    for chunk in prange(n_chunks):
        rs = np.empty(_RANGES, np.int64)
        re = np.empty(_RANGES, np.int64)
        rc = np.empty(_RANGES, np.int64)
        shell_end = np.empty(s_max + 2, np.int64)
        buf_d = np.empty(4096)
        buf_i = np.empty(4096, np.int64)
        bucket = np.empty(max(room, 4096), np.int64)
        scale_counts = np.empty(r2s.size + 1, np.int64)
        tmp_d = np.empty(4096)  # the k-nearest bucket sort's work space, grown with buf_d
        tmp_i = np.empty(4096, np.int64)
        bucket_counts = np.empty(2 * 4096 + 1, np.int64)
        prev = -1
        prev_dk = 0.0
        g0 = chunk * n_groups // n_chunks
        g1 = (chunk + 1) * n_groups // n_chunks
        for g in range(g0, g1):
            c = cell_of[queries[group_start[g]]]
            ci, cj, ck = cell_ijk[c, 0], cell_ijk[c, 1], cell_ijk[c, 2]
            n_shells = 0  # shells of this voxel whose point ranges are in rs/re/rc
            n_ranges = 0
            for qpos in range(group_start[g], group_start[g + 1]):
                q = queries[qpos]
                qx, qy, qz = pts[q, 0], pts[q, 1], pts[q, 2]
                margin = _face_margin(origin, h, ci, cj, ck, qx, qy, qz)
                hd = out_d2[qpos]
                hi = out_idx[qpos]
                if not knn_mode:
                    t = np.sqrt(r2)
                elif prev >= 0:
                    # the predecessor's k-th distance, a little wider: usually k points inside
                    # (its bound plus the distance between the two, sure to hold k, kept two
                    # thirds more candidates, to be sorted)
                    t = _KNN_GUESS * prev_dk
                else:
                    t = h  # a guess, grown below until it holds k points
                # A predecessor whose k-th neighbour coincides with it (duplicate points) gives
                # t = 0, which widening would keep at 0 forever: start from a fraction of a voxel.
                t = max(t, 1e-3 * h)
                want = k_first
                settled = True
                while True:
                    # round-off must not drop the k-th neighbour; a sphere holds exactly what
                    # is within its squared radius
                    t2 = t * t * (1.0 + 1e-12) if knn_mode else r2
                    s_need = 0
                    while s_need * h + margin < t and s_need < s_cover:
                        s_need += 1
                    if s_need > s_max:
                        settled = False
                        break
                    if knn_mode and s_need >= s_cover:
                        t2 = np.inf  # the shells hold every voxel: take every point
                    while n_shells <= s_need:
                        rs, re, rc = _room_for_shell(n_shells, rs, re, rc, n_ranges)
                        n_ranges = _shell(ci, cj, ck, n_shells, dims, cell_keys, lut, cell_start, rs, re, rc, n_ranges)
                        shell_end[n_shells] = n_ranges
                        n_shells += 1
                    # size the buffer for every candidate first, so the scan below is
                    # branch-free: each candidate is written, and kept if within t
                    total = 0
                    for r in range(shell_end[s_need]):
                        total += re[r] - rs[r]
                    if total > buf_d.size:
                        buf_d = np.empty(2 * total)
                        buf_i = np.empty(2 * total, np.int64)
                    kept = _U(0)
                    for r in range(shell_end[s_need]):
                        if _box_d2(origin, h, cell_ijk, rc[r], qx, qy, qz) > t2:
                            continue
                        for j in range(_U(rs[r]), _U(re[r])):
                            d2 = _d2(pts, j, qx, qy, qz)
                            buf_d[kept] = d2
                            buf_i[kept] = j
                            kept += _U(d2 <= t2)
                    m = np.int64(kept)
                    if not knn_mode:
                        break
                    if m >= want or s_need >= s_cover:
                        n = min(m, want)
                        if n <= _FEW:
                            if m > n:
                                _select(buf_d, buf_i, m, n)
                            _insertion_sort(buf_d, buf_i, n)
                            hd[:n] = buf_d[:n]
                            hi[:n] = buf_i[:n]
                        else:
                            if m > tmp_d.size:
                                tmp_d = np.empty(buf_d.size)
                                tmp_i = np.empty(buf_d.size, np.int64)
                                bucket = np.empty(buf_d.size, np.int64)
                                bucket_counts = np.empty(2 * buf_d.size + 1, np.int64)
                            _nearest_sorted(buf_d, buf_i, m, n, t2, bucket, bucket_counts, tmp_d, tmp_i, hd, hi)
                        if not (want < room and n == want and n >= 2 and hd[n - 1] <= tie_factor * hd[n - 2]):
                            break
                        want = room  # the (k + 1)-th ties with the k-th: ties may run on, list the room
                        continue
                    t *= _KNN_WIDEN
                if not settled:
                    out_n[qpos] = 0
                    done[qpos] = False
                    prev = -1
                    continue
                if knn_mode:
                    if n >= k_first:
                        prev = q
                        prev_dk = np.sqrt(hd[k_first - 1])
                    if counted:
                        _tie_counts(out_d2, qpos, n, ks, tie_factor, out_counts, out_sigma)
                        n = out_counts[qpos, ks.size - 1]  # neighbours past the largest scale's ties are not needed
                else:
                    out_total[qpos] = m  # before the cap
                    n = _partition_radius(buf_d, buf_i, m, r2s, k, hd, hi, bucket, scale_counts)
                out_n[qpos] = n
                done[qpos] = True


@njit(cache=True, inline="always")
def _prefix_end(d2, b, n, c, limit):
    """End of the prefix of row ``b`` of ``d2`` (its first ``n`` entries) at most ``limit``,
    scanning on from ``c`` (the end for a smaller limit)."""
    while c < n and d2[b, c] <= limit:
        c += 1
    return c


@njit(cache=True, parallel=True)
def count_within(d2, n, limits, counts):
    """Into ``counts`` (B, S): how many of the first ``n[b]`` squared distances of row ``b`` of
    ``d2`` are at most ``limits[b, s]`` (ascending in s).

    Each row must list the distances at most a limit before the others, as rows sorted by
    distance and rows grouped by scale do: a count is then the length of a prefix, found by one
    pass over the row for every scale together.
    """
    for b in prange(d2.shape[0]):
        c = 0
        for s in range(limits.shape[1]):
            c = _prefix_end(d2, b, n[b], c, limits[b, s])
            counts[b, s] = c


@njit(cache=True, inline="always")
def _tie_counts(d2, b, n, ks, tie_factor, counts, sigma):
    """Row ``b`` of the k-nearest scales: into ``counts[b, s]`` how many of the first ``n``
    squared distances of row ``b`` of ``d2`` (sorted) are at most ``tie_factor`` times the
    ``ks[s]``-th (the last where the row holds fewer; ties with the k-th included), into
    ``sigma[b, s]`` the distance to that neighbour (0 in an empty row)."""
    c = 0
    for s in range(ks.size):
        kth = min(ks[s], n) - 1
        kth_d2 = d2[b, kth] if kth >= 0 else 0.0
        c = _prefix_end(d2, b, n, c, kth_d2 * tie_factor)
        counts[b, s] = c
        sigma[b, s] = np.sqrt(kth_d2)


@njit(cache=True, parallel=True)
def count_ties(d2, n, ks, tie_factor, counts, sigma):
    """k-nearest scales on rows sorted by distance (:func:`_tie_counts` for every row): the
    scales of rows listed outside :func:`nearest`, which counts its own."""
    for b in prange(d2.shape[0]):
        _tie_counts(d2, b, n[b], ks, tie_factor, counts, sigma)


@njit(cache=True, inline="always")
def _min3(pts, j0, j1, qx, qy, qz, b0, b1, b2):
    """b0 <= b1 <= b2 updated with the squared distances of points j0 .. j1 - 1, without branches:
    a branch taken at random costs more than the whole update."""
    for j in range(_U(j0), _U(j1)):
        d2 = _d2(pts, j, qx, qy, qz)
        b2 = min(b2, max(b1, d2))
        b1 = min(b1, max(b0, d2))
        b0 = min(b0, d2)
    return b0, b1, b2


# This kernel stays long for the same reason as nearest: one shell walk per query keeping its
# three nearest in registers; split, they would pass through calls in the innermost loop.
@njit(cache=True, parallel=True)
def third_nearest(pts, cell_of, cell_ijk, cell_start, cell_keys, lut, dims, origin, h, queries, group_start,
                  s_max, n_chunks, out_d2, done):
    """Squared distance from each query to its third-nearest point, the query itself first (so its
    second-nearest other point): the k = 3 search of the area weights without a candidate list.

    Each query keeps its three smallest squared distances while it scans its own voxel, then those
    of the 26 around it that can still hold a nearer point (the distance to a neighbour voxel is
    the sum over axes of the squared distance to the faces between them, so a query near no face
    visits none), then, rarely, farther Chebyshev shells; it stops once no point beyond the
    shells scanned can be nearer (a point outside shell s is farther than s voxel sides plus the
    query's distance to its own voxel's faces). ``queries``, ``group_start`` as in
    :func:`nearest`; ``done[i]`` is False where ``s_max`` shells did not settle the query.
    """
    n_groups = group_start.size - 1
    n_chunks = max(1, min(n_groups, n_chunks))
    s_cover = max(dims[0], max(dims[1], dims[2]))
    slack = 1.0 + 1e-12  # round-off never skips a voxel that holds a nearer point
    for chunk in prange(n_chunks):
        rs = np.empty(_RANGES, np.int64)  # shell 1 is always listed
        re = np.empty(_RANGES, np.int64)
        rc = np.empty(_RANGES, np.int64)
        shell_end = np.empty(s_max + 2, np.int64)
        near_s = np.empty(27, np.int64)  # point range of voxel (di, dj, dk) at 9 (di + 1) + 3 (dj + 1) + dk + 1
        near_e = np.empty(27, np.int64)
        face = np.zeros((3, 3))  # squared distance from the query to the neighbour voxels along each axis
        g0 = chunk * n_groups // n_chunks
        g1 = (chunk + 1) * n_groups // n_chunks
        for g in range(g0, g1):
            c = cell_of[queries[group_start[g]]]
            ci, cj, ck = cell_ijk[c, 0], cell_ijk[c, 1], cell_ijk[c, 2]
            n_shells = 0
            n_ranges = 0
            near_s[:] = 0
            near_e[:] = 0
            for r in range(_shell(ci, cj, ck, 1, dims, cell_keys, lut, cell_start, rs, re, rc, 0)):
                slot = (9 * (cell_ijk[rc[r], 0] - ci + 1) + 3 * (cell_ijk[rc[r], 1] - cj + 1)
                        + cell_ijk[rc[r], 2] - ck + 1)
                near_s[slot] = rs[r]
                near_e[slot] = re[r]
            for qpos in range(group_start[g], group_start[g + 1]):
                q = queries[qpos]
                qx, qy, qz = pts[q, 0], pts[q, 1], pts[q, 2]
                margin = _face_margin(origin, h, ci, cj, ck, qx, qy, qz)
                b0, b1, b2 = _min3(pts, cell_start[c], cell_start[c + 1], qx, qy, qz, np.inf, np.inf, np.inf)
                settled = False
                if margin * margin >= b2 * slack or s_cover <= 0:
                    settled = b2 < np.inf
                else:
                    lx = qx - (origin[0] + ci * h)
                    ly = qy - (origin[1] + cj * h)
                    lz = qz - (origin[2] + ck * h)
                    face[0, 0], face[0, 2] = max(0.0, lx) ** 2, max(0.0, h - lx) ** 2
                    face[1, 0], face[1, 2] = max(0.0, ly) ** 2, max(0.0, h - ly) ** 2
                    face[2, 0], face[2, 2] = max(0.0, lz) ** 2, max(0.0, h - lz) ** 2
                    for a in range(3):  # the middle first: faces before edges, edges before corners
                        di = (a + 1) % 3
                        if face[0, di] > b2 * slack:
                            continue
                        for b in range(3):
                            dj = (b + 1) % 3
                            exy = face[0, di] + face[1, dj]
                            if exy > b2 * slack:
                                continue
                            for cc in range(3):
                                dk = (cc + 1) % 3
                                slot = 9 * di + 3 * dj + dk
                                if slot != 13 and exy + face[2, dk] <= b2 * slack:
                                    b0, b1, b2 = _min3(pts, near_s[slot], near_e[slot], qx, qy, qz, b0, b1, b2)
                    reach = h + margin
                    if reach * reach >= b2 * slack or s_cover <= 1:
                        settled = b2 < np.inf
                    else:  # an isolated point: farther shells, voxel by voxel
                        for s in range(2, s_max + 1):
                            while n_shells <= s:
                                rs, re, rc = _room_for_shell(n_shells, rs, re, rc, n_ranges)
                                n_ranges = _shell(ci, cj, ck, n_shells, dims, cell_keys, lut, cell_start, rs, re, rc, n_ranges)
                                shell_end[n_shells] = n_ranges
                                n_shells += 1
                            for r in range(shell_end[s - 1], shell_end[s]):
                                if _box_d2(origin, h, cell_ijk, rc[r], qx, qy, qz) <= b2 * slack:
                                    b0, b1, b2 = _min3(pts, rs[r], re[r], qx, qy, qz, b0, b1, b2)
                            reach = s * h + margin
                            if reach * reach >= b2 * slack or s >= s_cover:
                                settled = b2 < np.inf
                                break
                out_d2[qpos] = b2
                done[qpos] = settled


@njit(cache=True, parallel=True)
def nearest_by_scan(pts, queries, k, n_chunks, out_d2, out_idx, out_n, out_rows):
    """The k nearest of ``pts`` to each point ``queries[a]``, sorted, into row ``out_rows[a]`` of
    ``out_d2`` and ``out_idx`` (``out_n`` the count): a scan of every point, for the few queries
    the voxel shells cannot settle, in ``n_chunks`` runs of queries (one per thread).
    Squared distances are :func:`nearest`'s, to the bit (:func:`_d2`)."""
    n_pts = pts.shape[0]
    k = min(k, n_pts)
    n_chunks = max(1, min(queries.size, n_chunks))
    for chunk in prange(n_chunks):
        # one work array per thread: one per query cost more to fault in than to fill
        d = np.empty(n_pts)
        ix = np.empty(n_pts, np.int64)
        for a in range(chunk * queries.size // n_chunks, (chunk + 1) * queries.size // n_chunks):
            q = queries[a]
            qx, qy, qz = pts[q, 0], pts[q, 1], pts[q, 2]
            for j in range(n_pts):
                d[j] = _d2(pts, j, qx, qy, qz)
                ix[j] = j
            if n_pts > k:
                _select(d, ix, n_pts, k)
            _insertion_sort(d, ix, k)
            row = out_rows[a]
            out_d2[row, :k] = d[:k]
            out_idx[row, :k] = ix[:k]
            out_n[row] = k


#: Voxels of the dense voxel -> occupied-voxel look-up table, at most (else binary search).
LUT_CELLS = 2**24
#: The search kernels split their queries into this many runs of voxels per thread, handed to
#: the threads one at a time as each finishes its last: queries differ in cost, and an equal share
#: per thread left one idle at the end of every block (docs/performance.md).
_CHUNKS = 8


def _morton_table():
    """Morton code (bits x0 y0 z0 x1 y1 z1) of each 4 x 4 x 4 sub-voxel, by sx + 4 sy + 16 sz."""
    s = np.arange(64)
    sub = np.stack([s % 4, s // 4 % 4, s // 16], axis=1)
    code = np.zeros(64, np.int64)
    for bit in range(2):
        for axis in range(3):
            code |= ((sub[:, axis] >> bit) & 1) << (3 * bit + axis)
    return code


_MORTON = _morton_table()


@njit(cache=True)
def _sort_keys(xyz, origin, cell, dims, morton, out):
    """Each point's voxel key i + nx (j + ny k) times 64 plus its sub-voxel's Morton code, into
    ``out``: the arithmetic of ``floor((xyz - origin) / cell)`` and of four times it, to the bit."""
    for p in range(xyz.shape[0]):
        key = 0
        sub = 0
        scale = 1
        for a in range(3):
            f = (xyz[p, a] - origin[a]) / cell
            v = np.int64(np.floor(f))
            s = np.int64(np.floor(f * 4.0)) - 4 * v
            sub += min(max(s, 0), 3) * (1 << (2 * a))
            key += v * scale
            scale *= dims[a]
        out[p] = key * 64 + morton[sub]


@njit(cache=True)
def _voxel_runs(xyz, sort_key, order, points, cell_of):
    """Points in ``order`` into ``points``, each one's voxel run into ``cell_of``; returns the
    first position of each run (the keys in order, less their sub-voxel)."""
    n = len(order)
    starts = np.empty(n, np.int64)
    runs = 0
    last = -1
    for i in range(n):
        j = order[i]
        for a in range(3):
            points[i, a] = xyz[j, a]
        voxel = sort_key[j] >> 6
        if i == 0 or voxel != last:
            starts[runs] = i
            runs += 1
            last = voxel
        cell_of[i] = runs - 1
    return starts[:runs]


#: Most voxels of a grid's box: each has its key i + nx (j + ny k), and points are sorted by key
#: times 64 plus their sub-voxel, within int64.
KEY_VOXELS = 2.0**56


def key_cell(extent, cell):
    """``cell`` (a voxel side), grown where the box of ``extent`` (its sides) would hold more
    than KEY_VOXELS voxels: a tiny radius (1e-20 m) or a far outlier (1e7 m away on every
    axis) made keys that overflow, and searches that failed or missed neighbours. A voxel
    larger than asked still holds what the search looks for: slower, never wrong."""
    extent = np.maximum(np.asarray(extent, dtype=np.float64), 0.0)
    cell = max(float(cell), float(extent.max()) / 2.0**40, np.finfo(np.float64).tiny)  # extent / cell finite
    while True:
        voxels = float(np.prod(np.floor(extent / cell) + 1.0))
        if voxels <= KEY_VOXELS:
            return cell
        cell *= 1.01 * (voxels / KEY_VOXELS) ** (1.0 / 3.0)


class VoxelGrid:
    """Points sorted by voxel of side ``cell`` (at least :func:`key_cell`'s); ``order[i]`` is
    the input index of sorted point i."""

    def __init__(self, xyz, cell):
        xyz = np.ascontiguousarray(xyz, dtype=np.float64)
        self.origin = column_min(xyz)
        top = column_max(xyz)
        self.cell = key_cell(top - self.origin, cell) if len(xyz) else float(cell)
        # floor is monotonic: the largest voxel index is that of the largest coordinate
        self.dims = (np.floor((top - self.origin) / self.cell).astype(np.int64) + 1 if len(xyz)
                     else np.ones(3, np.int64))
        # Within a voxel, points go along a Morton curve of 4 x 4 x 4 sub-voxels, so that
        # consecutive queries are close and each can bound its search by its predecessor's.
        sort_key = np.empty(len(xyz), np.int64)
        _sort_keys(xyz, self.origin, self.cell, self.dims, _MORTON, sort_key)
        self.order = stable_order(sort_key)
        self.points = np.empty_like(xyz)
        self.cell_of = np.empty(len(xyz), np.int64)
        # the keys sorted: voxels start where they change (no np.unique, which sorts again)
        starts = _voxel_runs(xyz, sort_key, self.order, self.points, self.cell_of)
        self.cell_keys = sort_key[self.order[starts]] >> 6
        self.cell_start = np.append(starts, len(xyz)).astype(np.int64)
        d0, d1 = int(self.dims[0]), int(self.dims[1])
        self.cell_ijk = np.column_stack([self.cell_keys % d0, self.cell_keys // d0 % d1, self.cell_keys // (d0 * d1)])
        # A dense voxel -> occupied-voxel table makes look-ups O(1); skipped when the box is
        # huge and sparse (outliers far away), where a binary search over keys serves.
        n_cells = int(np.prod(self.dims.astype(np.float64)))
        self.lut = np.empty(0, np.int64)
        if n_cells <= max(LUT_CELLS, 8 * len(self.cell_keys)):
            self.lut = np.full(n_cells, -1, np.int64)
            self.lut[self.cell_keys] = np.arange(len(self.cell_keys))

    def _groups(self, queries):
        """``queries`` as int64 and the starts of their runs of one voxel."""
        queries = np.asarray(queries, dtype=np.int64)
        breaks = np.flatnonzero(np.diff(self.cell_of[queries])) + 1
        return queries, np.concatenate([[0], breaks, [len(queries)]]).astype(np.int64)

    def third_distances(self, queries, d2, done, s_max=4):
        """Squared distance of each sorted-order point ``queries[i]`` to its third-nearest point,
        itself included, into ``d2[i]``; ``done[i]`` False where ``s_max`` shells did not settle
        it (:func:`third_nearest`)."""
        queries, group_start = self._groups(queries)
        with parallel_chunksize(1):  # chunks to threads as they free up (_CHUNKS)
            third_nearest(self.points, self.cell_of, self.cell_ijk, self.cell_start, self.cell_keys, self.lut,
                          self.dims, self.origin, self.cell, queries, group_start, int(s_max),
                          _CHUNKS * get_num_threads(), d2, done)

    def search(self, queries, d2, idx, n, total, done, ks=None, radii2=None, cap=512, s_max=4, tie_factor=0.0,
               counts=None, sigma=None):
        """Neighbours of the sorted-order points ``queries`` into ``d2``, ``idx``, ``n``,
        ``total`` (spherical mode) and ``done``.

        Give ``ks`` (k-nearest scales, ascending) or ``radii2`` (squared radii, ascending, at
        most ``cap`` nearest). Row i gets n[i] neighbours; the rest of the row is left as is.
        With ``counts`` and ``sigma`` ((len(queries), len(ks)) arrays; k-nearest scales and
        ``tie_factor`` > 0 only) each settled query's scales are counted too (:func:`nearest`).
        """
        queries, group_start = self._groups(queries)
        if radii2 is None:
            ks = np.asarray(ks, dtype=np.int64)
            r2s = np.empty(0)
        else:
            r2s = np.asarray(radii2, dtype=np.float64)
            ks = np.array([cap], dtype=np.int64)
        if counts is None:
            counts, sigma = np.empty((len(queries), 0), np.int64), np.empty((len(queries), 0))
        with parallel_chunksize(1):  # chunks to threads as they free up (_CHUNKS)
            nearest(self.points, self.cell_of, self.cell_ijk, self.cell_start, self.cell_keys, self.lut,
                    self.dims, self.origin, self.cell, queries, group_start, ks, r2s, float(tie_factor),
                    int(s_max), _CHUNKS * get_num_threads(), d2, idx, n, total, done, counts, sigma)
