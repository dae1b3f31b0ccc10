"""The parameters and provenance of a report: what each input is (file, size, SHA-256, or the
clouds an archive was made from), its CRS and units, its counts, and the method and rendering
that made its signature."""
from __future__ import annotations

from pathlib import Path

from ..method.crs import crs_name
from ..method.scales import recorded_scales
from . import _page as page
from .sections import scales_text


def _files(side):
    """(path, size in bytes, SHA-256) of the side's input file and, for an archive, of the
    clouds it records having been made from."""
    from ..io.archive import sha256_of

    out = []
    path = side.result.cloud.path if side.result is not None else side.name
    if path and Path(path).is_file():
        out.append((str(path), Path(path).stat().st_size, sha256_of(path)))
    if side.result is None:
        sources = _recorded(side.signature.metadata.get("sources"), list)
        if sources is None or not all(isinstance(src, dict) for src in sources):
            # the metrics do not use it: the report says so rather than failing
            out.append(("made from: unreadable (the archive's sources record is not the JSON list lidar_sig "
                        "writes)", None, "?"))
            sources = []
        for src in sources:
            out.append((f"made from {src.get('path', '?')}", None, src.get("sha256", "?")))
    return out


def _recorded(text, kind):
    """A JSON record of an archive (``kind`` list or dict; empty when absent), or None when it is
    not one."""
    import json

    if text is None or text == "":
        return kind()
    try:
        value = json.loads(text) if isinstance(text, (str, bytes)) else text
    except ValueError:
        return None
    return value if isinstance(value, kind) else None


def provenance(sides, tags, render):
    """The table of parameters and provenance of the report's ``sides`` (one column each, headed
    by ``tags``): input files with size and SHA-256, CRS, units, counts, method and rendering."""
    from .. import __version__

    rows = []

    def row(label, values):
        rows.append([page.esc(label)] + list(values))

    metas = [s.signature.metadata for s in sides]
    files = []
    for side in sides:
        items = []
        for path, size, digest in _files(side):
            size_text = f", {size:,} bytes" if size is not None else ""
            items.append(f"<code>{page.esc(path)}</code>{size_text}<br>SHA-256 <code>{page.esc(digest)}</code>")
        files.append("<br>".join(items) or page.esc(side.name) + " (in memory)")
    row("file", files)
    row("kind", [{"archive": "signature archive", "signature": "signature (in memory)"}.get(s.kind, s.kind)
                 for s in sides])
    row("CRS", [page.esc(crs_name(m.get("crs") or (s.result.cloud.crs if s.result is not None else None))
                         or "none recorded (coordinates taken as metres)")
                for s, m in zip(sides, metas)])
    row("coordinate units", [page.esc(m.get("units", "?")) for m in metas])
    row("points", [f"{int(m.get('n_points', s.signature.n_points)):,}" for s, m in zip(sides, metas)])
    row("undefined saliency (left out of the signature)",
        [f"{int(m.get('n_undefined', s.signature.n_undefined)):,}" for s, m in zip(sides, metas)])
    row("neighbourhoods capped", [f"{int(m.get('n_capped', 0)):,} (at {int(m.get('max_neighbors', 0))} neighbours)"
                                  for m in metas])
    row("duplicate points (one location each)", [f"{int(m.get('n_duplicates', 0)):,}" for m in metas])
    row("withheld or noise points (left out)",
        [f"{int(m.get('n_excluded', 0)):,}" + (" (kept: keep_noise)" if m.get("keep_noise") else "") for m in metas])
    row("descriptor", [page.esc(f"{m.get('descriptor', '?')} {_params(m.get('descriptor_params'))}".strip())
                       for m in metas])
    row("strategy", [page.esc(m.get("strategy", "?")) for m in metas])
    row("scales", [page.esc(scales_text(m) + _as_given(m)) for m in metas])
    row("neighbour weights", [page.esc(m.get("weights", "?")) for m in metas])
    row("class table", [page.esc(s.signature.classes.name) for s in sides])
    row("signature frame", [f"{s.signature.frame.size} px, margin {s.signature.frame.margin} px" for s in sides])
    row("rendering", [page.esc(render)] * len(sides))
    row("made with", [page.esc(f"lidar_sig {m.get('lidar_sig_version', __version__)}") for m in metas])
    header = ["", *[f'<span class="{t.lower()}">{t}</span>' if t else "" for t in tags]]
    return page.table(header, rows)


def _params(params):
    params = _recorded(params, dict)
    if params is None:
        return "(parameters unreadable)"
    return ", ".join(f"{k}={v}" for k, v in sorted(params.items()))


def _as_given(m):
    scales = recorded_scales(m)
    if scales is not None and scales.normalized:
        return " (given as normalized " + ", ".join(f"{v:g}" for v in m.get("scale_values", [])) + ")"
    return ""
