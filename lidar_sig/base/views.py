"""How the public objects show themselves in a notebook: a card (``_repr_html_``) of a title, a
few facts, an optional small table and an optional picture, built from plain values (strings,
numbers, RGB arrays), so that objects of every layer can use it. Each object's one-line
``repr`` says the same in text.
"""
from __future__ import annotations

import base64
import html
from collections.abc import Iterable, Sequence
from typing import Any

#: Style of a card, scoped to it (a notebook's own styles are left alone).
CSS = (".lidar-sig-card{font-family:system-ui,sans-serif;font-size:13px;color:#222;display:flex;gap:14px;"
       "align-items:flex-start}.lidar-sig-card b{font-size:14px}.lidar-sig-card table{border-collapse:collapse;"
       "margin-top:4px}.lidar-sig-card td,.lidar-sig-card th{border:1px solid #ddd;padding:2px 6px;text-align:left}"
       ".lidar-sig-card th{background:#f4f4f4}.lidar-sig-card td.n{text-align:right;"
       "font-variant-numeric:tabular-nums}.lidar-sig-card .m{color:#666}.lidar-sig-card img{border:1px solid #eee}")


#: The longest one-line ``repr``, in characters: what a notebook's output cell shows unfolded.
REPR_LIMIT = 300


def short_name(name: Any) -> str:
    """A file's name without its folders (a path says where, a repr only which); other names as they are."""
    from pathlib import PurePath

    text = str(name)
    return PurePath(text).name or text


def one_line(text: str, limit: int = REPR_LIMIT) -> str:
    """``text`` (a ``<...>`` repr) on one line (a line break in a file name shown as ``\\n``,
    :func:`lidar_sig.base.errors.printable`), cut to ``limit`` characters, ending ``...>`` when cut."""
    from .errors import printable

    text = printable(text)
    return text if len(text) <= limit else text[:limit - 4] + "...>"


def esc(text: Any) -> str:
    """Text made safe for HTML."""
    return html.escape(str(text), quote=True)


def png_bytes(rgb: Any) -> bytes:
    """PNG file contents of an RGB picture (uint8, or floats in [0, 1])."""
    import cv2
    import numpy as np

    rgb = np.asarray(rgb)
    if rgb.dtype != np.uint8:
        rgb = np.clip(np.rint(rgb * 255.0), 0, 255).astype(np.uint8)
    ok, data = cv2.imencode(".png", np.ascontiguousarray(rgb[..., ::-1]))  # OpenCV is BGR
    if not ok:
        raise RuntimeError("OpenCV could not encode the picture as PNG")
    return data.tobytes()


def png_uri(rgb: Any) -> str:
    """A ``data:`` URI of an RGB picture, for an ``<img>``."""
    return "data:image/png;base64," + base64.b64encode(png_bytes(rgb)).decode("ascii")


def card(title: str, facts: Iterable[str] = (), *, header: Sequence[str] = (), rows: Iterable[Sequence[Any]] = (),
         numeric: Iterable[int] = (), image: Any = None, width: int = 200, note: str = "") -> str:
    """The HTML card of an object: ``title`` in bold, ``facts`` one per line, a table of ``rows``
    under ``header`` (the columns in ``numeric`` right-aligned), a picture (an RGB array)
    ``width`` pixels wide on the left, and a muted ``note``. Every text is escaped here."""
    numeric = set(numeric)
    picture = f'<img src="{png_uri(image)}" width="{width}" alt="{esc(title)}">' if image is not None else ""
    lines = "".join(f"<div>{esc(f)}</div>" for f in facts)
    rows = list(rows)
    grid = ""
    if rows:
        head = "".join(f"<th>{esc(h)}</th>" for h in header)
        body = "".join("<tr>" + "".join(f'<td class="n">{esc(c)}</td>' if i in numeric else f"<td>{esc(c)}</td>"
                                        for i, c in enumerate(row)) + "</tr>" for row in rows)
        grid = f"<table><thead><tr>{head}</tr></thead><tbody>{body}</tbody></table>"
    muted = f'<div class="m">{esc(note)}</div>' if note else ""
    return (f'<div class="lidar-sig-card"><style>{CSS}</style>{picture}<div><b>{esc(title)}</b>{lines}{grid}'
            f"{muted}</div></div>")
