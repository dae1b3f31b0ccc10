"""PNG files of pictures and of signatures (Sas, Sg), written atomically."""
from __future__ import annotations

import os
from typing import TYPE_CHECKING

from ..reporting.render import encode_png, signature_picture
from .atomic import atomic_output

if TYPE_CHECKING:
    from ..method.signature_raster import Signature


def write_png(path, data, *, overwrite=False):
    """Write PNG ``data`` (bytes, or an RGB uint8 picture) to ``path`` atomically."""
    if not isinstance(data, (bytes, bytearray)):
        data = encode_png(data)
    with atomic_output(path, overwrite=overwrite) as tmp:
        tmp.write_bytes(data)


def write_signature_png(path: str | os.PathLike[str], signature: Signature, *, kind: str = "sas", mode: str = "smooth",
                        overwrite: bool = False) -> None:
    """Write Sas (default, with the legend of its classes) or Sg of ``signature`` as a PNG file."""
    write_png(path, signature_picture(signature, kind, mode), overwrite=overwrite)
