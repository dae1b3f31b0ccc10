"""How the public objects show themselves in a notebook: a card (``_repr_html_``) of a title, a
few facts, an optional small table and an optional picture, built from plain values (strings,
numbers, RGB arrays), so that objects of every layer can use it. Each object's one-line
``repr`` says the same in text.
"""
from __future__ import annotations

import base64
import html
from pathlib import PurePath
from collections.abc import Iterable, Sequence
from typing import Any

#: Style of a card's parts, written inline on each element: a notebook that is not trusted
#: (executed by nbconvert or papermill, received, checked out) has its ``<style>`` blocks
#: stripped by JupyterLab's sanitizer, which keeps ``style`` attributes of the properties used
#: here. Inline styles also outrank a notebook's rules (JupyterLab right-aligns every cell and
#: centres tables with ``.jp-RenderedHTMLCommon`` rules): text cells left, numbers right, tables
#: against the left edge. The card has a white ground of its own, so that its dark text reads on
#: a dark theme too.
STYLES = {
    "card": "font-family:sans-serif;font-size:13px;color:#222;background:#fff;display:flex;gap:14px;"
            "align-items:flex-start;padding:4px;text-align:left",
    "text": "min-width:0",
    "title": "font-size:14px;font-weight:bold",
    "img": "border:1px solid #eee;max-width:none;flex-shrink:0",
    "scroll": "overflow-x:auto;max-width:100%",
    "table": "border-collapse:collapse;margin:4px 0 0 0;table-layout:auto;font-size:12px;color:#222",
    "cell": "border:1px solid #ddd;padding:2px 6px;vertical-align:top;line-height:1.35",
    "text_cell": "text-align:left;white-space:normal",
    "head": "background:#f4f4f4;font-weight:600",
    "number": "text-align:right;white-space:nowrap",
    "first": "text-align:left;white-space:nowrap",
    "muted": "color:#666",
}


#: The longest one-line ``repr``, in characters: what a notebook's output cell shows unfolded.
REPR_LIMIT = 300


def short_name(name: Any) -> str:
    """A file's name without its folders (a path says where, a repr only which); other names as they are."""
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


def outlined(rgb: Any, corners: Any, labels: Sequence[str], size: int = 360) -> Any:
    """(size, size, 3) uint8: the square RGB picture ``rgb`` (uint8, or floats in [0, 1])
    scaled to ``size`` pixels, the polygon of ``corners`` ((x, y) in pixels of ``rgb``) outlined
    and each corner's label beside it: above a corner of the upper half, below one of the lower
    half; centred on it, or starting (ending) at it near the left (right) edge."""
    import cv2
    import numpy as np

    rgb = np.asarray(rgb)
    if rgb.dtype != np.uint8:
        rgb = np.clip(np.rint(rgb * 255.0), 0, 255).astype(np.uint8)
    out = np.ascontiguousarray(cv2.resize(rgb, (size, size), interpolation=cv2.INTER_AREA))
    xy = np.asarray(corners, np.float64) * (size / rgb.shape[1])
    ink, scale, gap = (60, 60, 60), 0.62 * size / 360, max(3, size // 60)
    cv2.polylines(out, [np.rint(xy).astype(np.int32)], True, ink, max(1, size // 240), cv2.LINE_AA)
    for (x, y), label in zip(xy, labels):
        (w, h), _ = cv2.getTextSize(label, cv2.FONT_HERSHEY_SIMPLEX, scale, 1)
        left = x - w / 2 if size / 3 <= x <= 2 * size / 3 else x - gap if x < size / 3 else x - w + gap
        base = y - gap if y < size / 2 else y + gap + h
        org = (int(min(max(left, 1), size - w - 1)), int(min(max(base, h + 1), size - 2)))
        cv2.putText(out, label, org, cv2.FONT_HERSHEY_SIMPLEX, scale, ink, 1, cv2.LINE_AA)
    return out


def png_uri(rgb: Any) -> str:
    """A ``data:`` URI of an RGB picture, for an ``<img>``."""
    return "data:image/png;base64," + base64.b64encode(png_bytes(rgb)).decode("ascii")


def number(value: Any) -> str:
    """A value as a card shows it: whole numbers with thousands separators ("19,404"), every
    other value as its text."""
    import numbers

    if isinstance(value, numbers.Integral) and not isinstance(value, bool):
        return f"{int(value):,}"
    return str(value)


def card(title: str, facts: Iterable[str] = (), *, header: Sequence[str] = (), rows: Iterable[Sequence[Any]] = (),
         numeric: Iterable[int] = (), image: Any = None, width: int = 200, note: str = "") -> str:
    """The HTML card of an object: ``title`` in bold, ``facts`` one per line, a table of ``rows``
    under ``header`` (the columns in ``numeric`` right-aligned; whole numbers with thousands
    separators, :func:`number`), a picture (an RGB array) ``width`` pixels wide on the left, and
    a muted ``note``. Every text is escaped here; every style is inline (:data:`STYLES`)."""
    numeric = set(numeric)
    st = STYLES
    picture = (f'<img src="{png_uri(image)}" width="{width}" alt="{esc(title)}" style="{st["img"]}">'
               if image is not None else "")
    lines = "".join(f"<div>{esc(f)}</div>" for f in facts)
    rows = list(rows)
    grid = ""

    def cell(tag, i, text, extra=""):
        align = st["number"] if i in numeric else st["first"] if i == 0 else st["text_cell"]
        style = f"{st['cell']};{align}{extra}"
        kind = ' class="n"' if i in numeric else ""
        return f'<{tag}{kind} style="{style}">{esc(number(text))}</{tag}>'

    if rows:
        head = "".join(cell("th", i, h, ";" + st["head"]) for i, h in enumerate(header))
        body = "".join("<tr>" + "".join(cell("td", i, c) for i, c in enumerate(row)) + "</tr>" for row in rows)
        grid = (f'<div class="lidar-sig-scroll" style="{st["scroll"]}"><table class="lidar-sig-table" '
                f'style="{st["table"]}"><thead><tr>{head}</tr></thead><tbody>{body}</tbody></table></div>')
    muted = f'<div class="m" style="{st["muted"]}">{esc(note)}</div>' if note else ""
    return (f'<div class="lidar-sig-card" style="{st["card"]}">{picture}<div style="{st["text"]}">'
            f'<b style="{st["title"]}">{esc(title)}</b>{lines}{grid}{muted}</div></div>')


class Records(list):
    """A list of records (dicts of plain values) that prints in one line and shows as a card's
    table: a list like any other for indexing, iterating and JSON. A subclass names what the
    records are (``title``), the columns its card shows (``columns``: (header, function of a
    record giving the text, numeric?)) and what its line says (:meth:`summary`); ``facts``
    (keyword arguments) are kept for both."""

    title = "records"
    columns: tuple = ()
    #: Records shown in a card's table, at most.
    SHOWN = 20

    def __init__(self, records: Iterable[dict] = (), **facts: Any) -> None:
        super().__init__(records)
        self.facts = facts

    def summary(self) -> str:
        """What the records are, in a few words (the one-line repr after the type's name)."""
        return f"{len(self)} {self.title}"

    def __repr__(self) -> str:
        return one_line(f"<{type(self).__name__} {self.summary()}>")

    def _repr_html_(self) -> str:
        return self.card(type(self).__name__, [self.summary()])

    def card(self, title: str, facts: Iterable[str], *, note: str = "", **options: Any) -> str:
        """A card of ``title`` and ``facts`` above the table of the first :data:`SHOWN` records
        (``options`` as :func:`card`'s: a picture)."""
        columns = self.columns
        rows = [[show(r) for _, show, _ in columns] for r in self[:self.SHOWN]]
        more = f"... and {len(self) - self.SHOWN:,} more. " if len(self) > self.SHOWN else ""
        return card(title, facts, header=[h for h, _, _ in columns], rows=rows,
                    numeric=[i for i, (_, _, n) in enumerate(columns) if n], note=more + note, **options)

    def __reduce__(self):  # a copy or a pickle keeps the type and the facts
        return (_records, (type(self), list(self), self.facts))


def _records(kind, records, facts):
    return kind(records, **facts)


class Files(list):
    """The paths a call wrote, as a list, printed in one line: how many, in which folder, the
    first names."""

    def __repr__(self) -> str:
        folders = {str(PurePath(p).parent) for p in self}
        where = f" in {short_name(folders.pop())}" if len(folders) == 1 else ""
        names = ", ".join(PurePath(p).name for p in self[:4]) + (", ..." if len(self) > 4 else "")
        return one_line(f"<Files {len(self)} written{where}: {names}>")
