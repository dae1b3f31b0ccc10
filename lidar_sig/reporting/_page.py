"""HTML of the report: one self-contained page (styles inline, pictures as base64 PNG, no
script, no network), readable on a laptop screen and printable.

The same fragment, a ``<div class="lidar-sig-report">`` with its scoped style, makes the
standalone file and a notebook's display.
"""
from __future__ import annotations

import base64
import html

CSS = """
.lidar-sig-report { font-family: system-ui, -apple-system, "Segoe UI", Roboto, "Liberation Sans", sans-serif;
  color: #222; line-height: 1.45; max-width: 1240px; margin: 0 auto; padding: 0 16px 32px; font-size: 15px; }
.lidar-sig-report h1 { font-size: 1.5em; margin: 0.8em 0 0.2em; }
.lidar-sig-report h2 { font-size: 1.2em; margin: 1.6em 0 0.4em; border-bottom: 1px solid #ddd; padding-bottom: 0.2em; }
.lidar-sig-report p { margin: 0.4em 0; }
.lidar-sig-report .muted { color: #666; font-size: 0.9em; }
.lidar-sig-report table { border-collapse: collapse; margin: 0.5em 0; font-size: 0.92em; }
.lidar-sig-report th, .lidar-sig-report td { border: 1px solid #ddd; padding: 4px 8px; text-align: left;
  vertical-align: top; }
.lidar-sig-report th { background: #f4f4f4; }
.lidar-sig-report td.num { text-align: right; font-variant-numeric: tabular-nums; white-space: nowrap; }
.lidar-sig-report code { font-size: 0.92em; word-break: break-all; }
.lidar-sig-report .a { color: #2166ac; font-weight: 600; }
.lidar-sig-report .b { color: #b2182b; font-weight: 600; }
.lidar-sig-report .warnings { background: #fff6d6; border: 1px solid #e8cf6a; padding: 8px 12px; border-radius: 4px; }
.lidar-sig-report .ok { background: #eef7ee; border: 1px solid #b9dcb9; padding: 8px 12px; border-radius: 4px; }
.lidar-sig-report .grid { display: grid; grid-template-columns: repeat(2, minmax(0, 1fr)); gap: 12px 18px;
  align-items: start; }
.lidar-sig-report figure { margin: 0; }
.lidar-sig-report figure img { max-width: 100%; height: auto; display: block; border: 1px solid #eee; }
.lidar-sig-report figcaption { font-size: 0.88em; color: #444; margin-top: 4px; }
@media print {
  .lidar-sig-report { max-width: none; font-size: 10pt; padding: 0; }
  .lidar-sig-report h2 { break-after: avoid; }
  .lidar-sig-report figure, .lidar-sig-report table, .lidar-sig-report .warnings { break-inside: avoid; }
  @page { margin: 12mm; }
}
"""


def esc(text):
    """Text made safe for HTML."""
    return html.escape(str(text), quote=True)


def image(png, alt, *, caption=None):
    """A figure with an embedded PNG and an optional caption (HTML already escaped)."""
    data = base64.b64encode(png).decode("ascii")
    cap = f"<figcaption>{caption}</figcaption>" if caption else ""
    return f'<figure><img src="data:image/png;base64,{data}" alt="{esc(alt)}">{cap}</figure>'


def table(header, rows, *, numeric=(), cls=None):
    """A table; cells are HTML already escaped; columns in ``numeric`` are right-aligned."""
    head = "".join(f"<th>{h}</th>" for h in header)
    body = "".join("<tr>" + "".join(f'<td class="num">{c}</td>' if i in numeric else f"<td>{c}</td>"
                                    for i, c in enumerate(row)) + "</tr>" for row in rows)
    attr = f' class="{cls}"' if cls else ""
    return f"<table{attr}><thead><tr>{head}</tr></thead><tbody>{body}</tbody></table>"


def section(title, *parts, anchor=None):
    ident = f' id="{esc(anchor)}"' if anchor else ""
    return f"<section{ident}><h2>{esc(title)}</h2>{''.join(parts)}</section>"


def fragment(title, subtitle, sections):
    """The report's body with its style, for a notebook or the standalone page."""
    return (f'<div class="lidar-sig-report"><style>{CSS}</style><h1>{esc(title)}</h1>'
            f'<p class="muted">{subtitle}</p>{"".join(sections)}</div>')


def document(title, body):
    """A whole HTML page around :func:`fragment`'s output."""
    return ("<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">"
            "<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\"><link rel=\"icon\" href=\"data:,\">"
            f"<title>{esc(title)}</title></head><body style=\"margin:0;background:#fff\">{body}</body></html>\n")
