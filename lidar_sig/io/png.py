"""PNG files of pictures and of signatures (Sas, Sg), written atomically: PNG encoding and the
picture of a signature in its triangle (which :mod:`lidar_sig.reporting.render` draws on too),
with OpenCV imported on first use."""
from __future__ import annotations

import os
from typing import TYPE_CHECKING

import numpy as np

from ..method.signature_raster import to_uint8
from .atomic import atomic_output

if TYPE_CHECKING:
    from ..method.signature_raster import Signature

#: Names of the triangle's vertices V_l, V_s, V_p as the pictures label them.
VERTEX_LABELS = ("line", "surface", "point")
_FONT = 0  # cv2.FONT_HERSHEY_SIMPLEX
_INK = (40, 40, 40)
_EDGE = (90, 90, 90)


def _cv2():
    import cv2

    return cv2


def signature_image(signature, kind="sas", mode="smooth", *, scale=1):
    """(H, W, 3) uint8 picture of Sas or Sg: white outside the triangle, vertices labelled.

    Sg is drawn dark on white (1 - Sg), like Sas. A whole ``scale`` > 1 enlarges the pixels
    (each a ``scale`` x ``scale`` square) before the triangle and labels are drawn, for small
    frames.
    """
    sg, sas = signature.render(mode)
    img = sas if kind == "sas" else np.repeat(1.0 - sg[..., None], 3, axis=2)
    rgb = to_uint8(img)
    rgb[~signature.frame.mask()] = 255
    if scale > 1:
        rgb = np.ascontiguousarray(np.repeat(np.repeat(rgb, scale, axis=0), scale, axis=1))
    return draw_triangle(rgb, signature.frame, scale=scale)


def draw_triangle(rgb, frame, *, labels=VERTEX_LABELS, scale=1.0):
    """Draw the frame's triangle (anti-aliased) and its vertex labels on ``rgb``, in place and
    returned; ``scale`` is the picture's size over the frame's."""
    cv2 = _cv2()
    v = frame.vertices * scale
    shift = 4  # sub-pixel vertices: OpenCV takes fixed-point coordinates with 4 fractional bits
    pts = np.rint(v * (1 << shift)).astype(np.int32).reshape(-1, 1, 2)
    cv2.polylines(rgb, [pts], True, _EDGE, 1, cv2.LINE_AA, shift)
    font = max(0.45 * frame.size * scale / 512, 0.4)
    for (x, y), label, where in zip(v, labels, ("top", "right", "left")):
        (w, h), _ = cv2.getTextSize(label, _FONT, font, 1)
        if where == "top":
            org = (x - w / 2, y - 0.35 * h)
        elif where == "right":
            org = (x - w, y + 1.6 * h)
        else:
            org = (x, y + 1.6 * h)
        org = (int(np.clip(org[0], 0, rgb.shape[1] - w)), int(np.clip(org[1], h, rgb.shape[0] - 2)))
        cv2.putText(rgb, label, org, _FONT, font, _INK, 1, cv2.LINE_AA)
    return rgb


def encode_png(rgb):
    """PNG file contents (bytes) of an RGB uint8 picture."""
    cv2 = _cv2()
    ok, data = cv2.imencode(".png", np.ascontiguousarray(np.asarray(rgb)[..., ::-1]))  # OpenCV is BGR
    if not ok:
        raise RuntimeError("OpenCV could not encode the picture as PNG")
    return data.tobytes()


def write_png(path, data, *, overwrite=False):
    """Write PNG ``data`` (bytes, or an RGB uint8 picture) to ``path`` atomically."""
    if not isinstance(data, (bytes, bytearray)):
        data = encode_png(data)
    with atomic_output(path, overwrite=overwrite) as tmp:
        tmp.write_bytes(data)


def write_signature_png(path: str | os.PathLike[str], signature: Signature, *, kind: str = "sas", mode: str = "smooth",
                        overwrite: bool = False) -> None:
    """Write Sas (default) or Sg of ``signature`` as a PNG file."""
    write_png(path, signature_image(signature, kind, mode), overwrite=overwrite)
