"""The kernels (numba) of a tile's load: staged records to centred metres, cut to a plan-view
box, in two passes over the records (numpy took a column stack, the conversion, four
comparisons and four masked copies, a sixth of a tile's time: docs/performance.md, "Sorting and
loading"). The arithmetic is that of ``(c - centre) * factors``, to the bit."""
from __future__ import annotations

from numba import njit


@njit(cache=True)
def _metres(x, y, i, centre, factors, x0, y0, x1, y1):
    """Record ``i``'s plan-view centred metres and whether they lie within [x0, x1] x [y0, y1]."""
    mx = (x[i] - centre[0]) * factors[0]
    my = (y[i] - centre[1]) * factors[1]
    return mx, my, mx >= x0 and mx <= x1 and my >= y0 and my <= y1


@njit(cache=True)
def count_within(x, y, centre, factors, x0, y0, x1, y1):
    """How many records of coordinates ``x``, ``y`` (the files' units) lie within [x0, x1] x
    [y0, y1] in centred metres: the size of :func:`metres_within`'s outputs."""
    m = 0
    for i in range(len(x)):
        m += _metres(x, y, i, centre, factors, x0, y0, x1, y1)[2]
    return m


@njit(cache=True)
def metres_within(x, y, z, ids, labels, centre, factors, x0, y0, x1, y1, xyz, raw, ids_out, labels_out):
    """Write the records (coordinates ``x``, ``y``, ``z`` in the files' units, ``ids``,
    ``labels``) that :func:`count_within` counts, in order, to ``xyz`` (centred metres),
    ``raw`` (the files' units), ``ids_out`` and ``labels_out``, each of that size."""
    m = 0
    for i in range(len(x)):
        mx, my, inside = _metres(x, y, i, centre, factors, x0, y0, x1, y1)
        if inside:
            xyz[m, 0], xyz[m, 1], xyz[m, 2] = mx, my, (z[i] - centre[2]) * factors[2]
            raw[m, 0], raw[m, 1], raw[m, 2] = x[i], y[i], z[i]
            ids_out[m], labels_out[m] = ids[i], labels[i]
            m += 1
