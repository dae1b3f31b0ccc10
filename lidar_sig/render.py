"""Signature images for people: PNG files of Sas and Sg with the reference triangle."""
from __future__ import annotations

import numpy as np
from PIL import Image, ImageDraw

from .io.atomic import atomic_output
from .signature import to_uint8


def signature_image(signature, kind="sas", mode="smooth"):
    """(H, W, 3) uint8 picture of Sas or Sg: white outside the triangle, vertices labelled.

    Sg is drawn dark on white (1 - Sg), like Sas.
    """
    frame = signature.frame
    img = signature.sas(mode) if kind == "sas" else np.repeat(1.0 - signature.sg(mode)[..., None], 3, axis=2)
    rgb = to_uint8(img)
    rgb[~frame.mask()] = 255
    pil = Image.fromarray(rgb)
    draw = ImageDraw.Draw(pil)
    v = frame.vertices
    draw.polygon([tuple(p) for p in v], outline=(90, 90, 90))
    for (x, y), label, dx, dy in zip(v, ("Cl", "Cs", "Cp"), (4, -16, 2), (-13, 2, 2)):
        draw.text((x + dx, max(0.0, y + dy)), label, fill=(0, 0, 0))
    return np.asarray(pil)


def write_signature_png(path, signature, *, kind="sas", mode="smooth", overwrite=False):
    """Write Sas (default) or Sg of ``signature`` as a PNG file."""
    with atomic_output(path, overwrite=overwrite) as tmp:
        Image.fromarray(signature_image(signature, kind, mode)).save(tmp, format="PNG")
