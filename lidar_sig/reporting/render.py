"""Images for people, drawn with OpenCV: Sas and Sg in their triangle (docs/method.md, "Signatures"), the difference
of two signatures, a top view of a cloud coloured by its saliency, PNG encoding.

Every picture is an (H, W, 3) uint8 RGB array; :mod:`lidar_sig.io.png` encodes it as PNG
(``encode_png``) and writes it, and draws a signature in its triangle (``signature_image``, which
a signature's PNG file needs below the reports). OpenCV is imported on first use, so computing saliency alone
never loads it.
"""
from __future__ import annotations

import numpy as np

# a signature's picture and PNG bytes are made in io.png, below the reports, which take them from here too
from ..io.png import VERTEX_LABELS, draw_triangle, encode_png, signature_image  # noqa: F401
from ..method.signature_raster import RENDERINGS, smooth_counts, to_uint8
from ..numerics.bounds import bounds, nan_rows
#: ColorBrewer RdBu, blue (negative) to red (positive), for signed differences.
DIVERGING = np.array([(5, 48, 97), (33, 102, 172), (67, 147, 195), (146, 197, 222), (209, 229, 240),
                      (247, 247, 247), (253, 219, 199), (244, 165, 130), (214, 96, 77), (178, 24, 43),
                      (103, 0, 31)], dtype=np.float64)
#: Quantile of the absolute differences at which the difference image saturates.
SATURATION = 0.99
#: Grey of points with undefined saliency in the top view.
UNDEFINED_GREY = (150, 150, 150)
_FONT = 0  # cv2.FONT_HERSHEY_SIMPLEX
_INK = (40, 40, 40)
_EDGE = (90, 90, 90)


def _cv2():
    import cv2

    return cv2


def point_shares(signature, mode="smooth"):
    """(H, W) share of the signature's points per pixel; smoothed as the ``smooth`` rendering
    smooths (its Gaussian, see :mod:`lidar_sig.method.signature_raster`), per pixel otherwise."""
    if mode not in RENDERINGS:
        from ..base.errors import LidarSigError

        raise LidarSigError(f"unknown rendering {mode!r}; use one of {', '.join(RENDERINGS)}")
    total = signature.total[None]
    if mode == "smooth":
        total = smooth_counts(total, signature.frame)
    return total[0] / max(signature.n_points, 1)


def difference(a, b, mode="smooth"):
    """(H, W) share of B's points minus share of A's per pixel (see :func:`point_shares`)."""
    a.check_comparable(b)
    return point_shares(b, mode) - point_shares(a, mode)


def difference_image(a, b, mode="smooth", *, names=("A", "B")):
    """Picture of :func:`difference` in diverging colours (blue where A has the larger share of
    its points, red where B has), symmetric about white at 0 and saturated at the
    :data:`SATURATION` quantile of the absolute differences; a legend strip below gives the
    scale."""
    cv2 = _cv2()
    d = difference(a, b, mode)
    frame = a.frame
    # saturate at a high quantile of the differing pixels, so that one peak (often at the
    # surface vertex) does not leave every other change invisible
    changed = np.abs(d[d != 0])
    top = float(np.quantile(changed, SATURATION)) if changed.size else 1.0
    rgb = diverging(d / top)
    rgb[~frame.mask()] = 255
    draw_triangle(rgb, frame)
    # legend: a colour ramp from -top to +top, its ends and centre labelled
    size = frame.size
    legend = np.full((62, size, 3), 255, np.uint8)
    x0, x1 = size // 8, size - size // 8
    ramp = diverging(np.linspace(-1.0, 1.0, x1 - x0))
    legend[8:24, x0:x1] = ramp[None]
    cv2.rectangle(legend, (x0, 8), (x1 - 1, 23), _EDGE, 1)
    font = 0.42
    per_mille = 1000 * top
    texts = ((f"< -{per_mille:.2g}", x0, "left"), ("0", (x0 + x1) // 2, "centre"), (f"> +{per_mille:.2g}", x1, "right"),
             (f"more of {names[0]}", x0, "left"), (f"more of {names[1]}", x1, "right"))
    for i, (text, x, align) in enumerate(texts):
        (w, h), _ = cv2.getTextSize(text, _FONT, font, 1)
        x = x if align == "left" else x - w // 2 if align == "centre" else x - w
        y = 24 + 4 + h if i < 3 else 24 + 8 + 2 * h + 4
        cv2.putText(legend, text, (int(x), int(y)), _FONT, font, _INK, 1, cv2.LINE_AA)
    caption = "per mille of the points per pixel"
    (w, h), _ = cv2.getTextSize(caption, _FONT, font, 1)
    cv2.putText(legend, caption, ((size - w) // 2, 24 + 8 + 2 * h + 4), _FONT, font, _INK, 1, cv2.LINE_AA)
    return np.vstack([rgb, legend])


def diverging(values):
    """RGB uint8 of values in [-1, 1] on the :data:`DIVERGING` ramp (white at 0)."""
    return ramp((np.asarray(values) + 1.0) / 2.0, DIVERGING)


def ramp(values, colours):
    """RGB uint8 of values in [0, 1] (clipped) interpolated linearly along ``colours`` ((K, 3)
    RGB stops, evenly spaced from 0 to 1)."""
    t = np.clip(values, 0.0, 1.0) * (len(colours) - 1)
    stops = np.arange(len(colours))
    out = np.stack([np.interp(t, stops, colours[:, c]) for c in range(3)], axis=-1)
    return np.rint(out).astype(np.uint8)


def top_view(xyz, saliency, *, max_side=900, points_per_cell=2.5):
    """Top view of a cloud, (H, W, 3) uint8: each cell shows RGB = (Cl, Cs, Cp) of its highest
    point (what is seen from above), grey where that point's saliency is undefined, white where
    no point falls (single empty cells among occupied ones are filled from their neighbours);
    north up.

    The cell side is chosen so that a cell holds about ``points_per_cell`` points on average,
    but the picture's longer side stays within ``max_side`` cells: a million points cost one
    sort, and the picture's size does not grow with the cloud. Returns the picture and the cell
    side in the coordinates' unit.
    """
    xyz = np.asarray(xyz, dtype=np.float64)
    lo, hi = bounds(xyz[:, :2])
    extent = np.maximum(hi - lo, 1e-9)
    cell = max(np.sqrt(extent[0] * extent[1] * points_per_cell / len(xyz)), extent.max() / max_side)
    cols = np.minimum(((xyz[:, 0] - lo[0]) / cell).astype(np.int64), int(extent[0] / cell))
    rows = np.minimum(((hi[1] - xyz[:, 1]) / cell).astype(np.int64), int(extent[1] / cell))
    h, w = int(rows.max()) + 1, int(cols.max()) + 1
    flat = rows * w + cols
    order = np.lexsort((xyz[:, 2], flat))  # by cell, then height: the last of a cell is its top
    last = np.ones(len(order), bool)
    last[:-1] = flat[order][1:] != flat[order][:-1]
    top = order[last]
    values = np.asarray(saliency, dtype=np.float64)[top]
    colour = to_uint8(np.nan_to_num(values, nan=0.0))
    colour[nan_rows(values)] = UNDEFINED_GREY
    rgb = np.full((h * w, 3), 255, np.uint8)
    rgb[flat[top]] = colour
    rgb = rgb.reshape(h, w, 3)
    # cells left empty by chance among occupied ones take their neighbours' colour; empty
    # areas (outside the survey, water) stay white
    cv2 = _cv2()
    occupied = np.zeros(h * w, np.uint8)
    occupied[flat] = 1
    occupied = occupied.reshape(h, w)
    holes = cv2.morphologyEx(occupied, cv2.MORPH_CLOSE, np.ones((3, 3), np.uint8)) & (1 - occupied)
    if holes.any():
        rgb = cv2.inpaint(rgb, holes, 1, cv2.INPAINT_TELEA)
    return rgb, cell


def top_view_image(xyz, saliency, *, unit="m", display=640, span=None):
    """:func:`top_view` at about ``display`` px (cells kept square and crisp), with a scale bar
    and a key: the colour triangle of (Cl, Cs, Cp) and the grey of undefined points.

    ``span`` is the ground length (coordinate units) drawn as ``display`` px; by default the
    cloud's longer side. Two clouds drawn with the same span share one scale."""
    from ..method.signature_raster import Frame

    cv2 = _cv2()
    raster, cell = top_view(xyz, saliency)
    factor = display / max(raster.shape[:2])
    if span is not None:
        factor = min(factor, display * cell / span)
    interpolation = cv2.INTER_NEAREST if factor >= 1 else cv2.INTER_AREA  # AREA: no aliasing
    size = (max(1, round(raster.shape[1] * factor)), max(1, round(raster.shape[0] * factor)))
    view = cv2.resize(raster, size, interpolation=interpolation)
    metres_per_px = cell / factor
    key_frame = Frame(220, 26)
    key = colour_key(key_frame)
    panel = np.full((max(view.shape[0], key.shape[0] + 90), key.shape[1] + 20, 3), 255, np.uint8)
    panel[:key.shape[0], 10:10 + key.shape[1]] = key
    y = key.shape[0] + 16
    cv2.rectangle(panel, (22, y - 10), (36, y + 2), UNDEFINED_GREY, -1)
    cv2.putText(panel, "undefined", (44, y + 1), _FONT, 0.42, _INK, 1, cv2.LINE_AA)
    bar, label = scale_bar(metres_per_px, display // 4, unit)  # one bar for views of one span
    y += 34
    cv2.line(panel, (22, y), (22 + bar, y), _INK, 2)
    for x in (22, 22 + bar):
        cv2.line(panel, (x, y - 5), (x, y + 5), _INK, 1)
    cv2.putText(panel, label, (22, y + 20), _FONT, 0.42, _INK, 1, cv2.LINE_AA)
    cv2.putText(panel, "north up", (22, y + 40), _FONT, 0.42, _INK, 1, cv2.LINE_AA)
    out = np.full((max(view.shape[0], panel.shape[0]), view.shape[1] + panel.shape[1], 3), 255, np.uint8)
    out[:view.shape[0], :view.shape[1]] = view
    out[:panel.shape[0], view.shape[1]:] = panel
    cv2.rectangle(out, (0, 0), (view.shape[1] - 1, view.shape[0] - 1), (200, 200, 200), 1)
    return out


def scale_bar(units_per_px, max_px, unit):
    """Length in px and label of a round scale bar (1, 2 or 5 times a power of ten units) no
    longer than ``max_px``."""
    longest = max(units_per_px * max_px, 1e-9)
    power = 10.0 ** np.floor(np.log10(longest))
    length = max(m * power for m in (1, 2, 5) if m * power <= longest)
    return max(1, int(round(length / units_per_px))), f"{length:g} {unit}"


def colour_key(frame):
    """The triangle coloured RGB = (Cl, Cs, Cp) of each pixel's barycentric position, labelled:
    the key of :func:`top_view`."""
    c = np.arange(frame.size) + 0.5
    x, y = np.meshgrid(c, c)
    v = frame.vertices
    m = np.vstack([v.T, np.ones(3)])
    bary = np.linalg.solve(m, np.vstack([x.ravel(), y.ravel(), np.ones(x.size)])).T
    rgb = np.ascontiguousarray(to_uint8(np.clip(bary, 0.0, 1.0)).reshape(frame.size, frame.size, 3))
    rgb[~frame.mask()] = 255
    return draw_triangle(rgb, frame)
