"""The HTML report: the paper's figures for one cloud, or for the comparison of two.

A :class:`Report` is one self-contained HTML page (pictures embedded, no network) with, for a
comparison, Sg and Sas of both clouds in the same frame and the difference of the two
signatures, the metrics with what each reacts to, the run's warnings, the pdfs of Egeom, the
class-wise pdfs of Cl, Cs and Cp, the class composition, a top view of each cloud coloured by
its saliency, and the parameters and provenance of the run. In a notebook it displays itself;
``save`` writes the page, ``save_plots`` every figure as PNG.

>>> import lidar_sig as ls                                         # doctest: +SKIP
>>> ls.report("epoch1.laz", "epoch2.laz").save("report.html")      # doctest: +SKIP
"""
from __future__ import annotations

import datetime
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import LidarSigError
from ..progress import step
from . import page

#: File names of the comparison report's figures (``save_plots``), in the page's order.
COMPARISON_PLOTS = ("sas_a.png", "sas_b.png", "sg_a.png", "sg_b.png", "difference.png", "classes.png",
                    "egeom.png", "saliency_by_class.png", "top_view_a.png", "top_view_b.png")
#: File names of the single-cloud report's figures.
SIGNATURE_PLOTS = ("sas.png", "sg.png", "classes.png", "egeom.png", "saliency_by_class.png", "top_view.png")
HTML_EXTENSIONS = (".html", ".htm")


@dataclass
class Report:
    """An HTML report: ``title``, the page's ``body`` (an HTML fragment with its style) and its
    ``figures`` (file name -> PNG bytes), in the page's order."""

    title: str
    body: str
    figures: dict = field(default_factory=dict)

    def html(self):
        """The whole page, as text."""
        return page.document(self.title, self.body)

    def _repr_html_(self):  # a notebook shows the report in place
        return self.body

    def save(self, path, *, overwrite=False):
        """Write the page to ``path`` (.html), atomically; refuses an existing file unless
        ``overwrite``."""
        from ..io.atomic import atomic_output

        check_report_path(path)
        with step(f"writing {Path(path).name}"), atomic_output(path, overwrite=overwrite) as tmp:
            tmp.write_text(self.html(), encoding="utf-8")

    def save_plots(self, folder, *, overwrite=False):
        """Write every figure as a PNG file in ``folder`` (made if missing, its parent must
        exist); refuses existing files unless ``overwrite``. Returns the paths written."""
        from ..render import write_png

        folder = Path(folder)
        check_plots_folder(folder, self.figures, overwrite=overwrite)
        folder.mkdir(exist_ok=True)
        paths = []
        with step(f"writing {len(self.figures)} plots in {folder}"):
            for name, png in self.figures.items():
                write_png(folder / name, png, overwrite=overwrite)
                paths.append(folder / name)
        return paths


def check_report_path(path, *, overwrite=True):
    """Refuse a report path without an .html extension (and, unless ``overwrite``, one that
    exists) or in a folder that is missing or not writable: before any computing."""
    from ..io.atomic import check_output

    if Path(path).suffix.lower() not in HTML_EXTENSIONS:
        raise LidarSigError("the report is written as .html", path=path)
    check_output(path, overwrite=overwrite)
    _check_writable(Path(path).parent, path)


def check_plots_folder(folder, names, *, overwrite=False):
    """Refuse a plots folder that is a file, whose parent is missing or not writable, or that
    holds a file of ``names`` already (unless ``overwrite``): before any computing."""
    folder = Path(folder)
    if folder.exists() and not folder.is_dir():
        raise LidarSigError("is a file, not a folder for the plots; give a folder", path=folder)
    parent = folder if folder.is_dir() else folder.parent
    if not (parent if str(parent) else Path(".")).is_dir():
        raise LidarSigError("the folder above the plots folder does not exist; create it first", path=folder)
    _check_writable(parent, folder)
    if not overwrite:
        taken = [n for n in names if (folder / n).exists()]
        if taken:
            raise LidarSigError(f"already holds {', '.join(taken)}; pass --overwrite to replace them "
                                "or give another folder", path=folder)


def _check_writable(folder, path):
    import os

    folder = folder if str(folder) else Path(".")
    if folder.is_dir() and not os.access(folder, os.W_OK | os.X_OK):
        raise LidarSigError("cannot write in this folder (permission denied); choose another", path=path)


def report(a, b=None, pipeline=None, *, render=None, columns=None):
    """The report of one cloud, or of the comparison of two.

    Parameters
    ----------
    a, b : str, Path, PointCloud, Signature, Result or Comparison
        Clouds or archives as :func:`lidar_sig.comparison.compare_sources` takes them (``b``
        None for one cloud's report), a pipeline ``Result``, or an already made
        ``Comparison``.
    pipeline : Pipeline, optional
        The method for clouds; default ``Pipeline()``.
    render : str, optional
        Rendering of Sg and Sas (see :mod:`lidar_sig.signature`); default "smooth".
    """
    from ..comparison import Comparison, compare_sources

    if isinstance(a, Comparison):
        return comparison_report(a)
    if b is not None:
        return comparison_report(compare_sources(a, b, pipeline, render=render, columns=columns))
    return signature_report(_side(a, pipeline, columns), render=render or "smooth")


def _side(x, pipeline, columns):
    from ..comparison import Side, _load, _name
    from ..pipeline import Pipeline, Result
    from ..signature import Signature

    if isinstance(x, Result):
        return Side(_name(x.cloud), x.signature, x)
    loaded = _load(x, columns)
    if isinstance(loaded, Signature):
        return Side(_name(x), loaded)
    result = (pipeline or Pipeline()).run(loaded)
    return Side(_name(x), result.signature, result)


# -- the two reports ------------------------------------------------------------------------

def comparison_report(comparison):
    """The :class:`Report` of a :class:`lidar_sig.comparison.Comparison`."""
    from .. import render as images
    from . import figures

    c = comparison
    sides = (c.a, c.b)
    sigs = [s.signature for s in sides]
    labels = [f"{tag}: {Path(s.name).name}" for s, tag in zip(sides, "AB")]
    with step("rendering the report", rendering=c.render):
        pngs = {}
        for side, tag in zip(sides, "ab"):
            pngs[f"sas_{tag}.png"] = images.encode_png(images.signature_image(side.signature, "sas", c.render))
            pngs[f"sg_{tag}.png"] = images.encode_png(images.signature_image(side.signature, "sg", c.render))
        pngs["difference.png"] = images.encode_png(images.difference_image(*sigs, c.render, names=("A", "B")))
        pngs["classes.png"] = figures.class_composition(sigs, labels)
        pngs["egeom.png"] = figures.egeom_pdfs(sigs, labels)
        pngs["saliency_by_class.png"] = figures.saliency_pdfs(sigs, labels)
        span = _shared_span(sides)
        for side, tag in zip(sides, "ab"):
            if side.result is not None:
                pngs[f"top_view_{tag}.png"] = _top_view(side, span)
    with step("checksums of the inputs"):
        provenance = _provenance(sides, ("A", "B"), c.render)
    title = f"lidar_sig comparison: {Path(c.a.name).name} and {Path(c.b.name).name}"
    parts = [
        _summary(sides, ("A", "B"), c),
        page.section("Warnings", _warnings(c.warnings), anchor="warnings"),
        page.section("Metrics", _metrics_table(c.metrics), anchor="metrics"),
        page.section("Signatures", _signatures_intro(c.render), _class_legend(sigs),
                     '<div class="grid">'
                     + page.image(pngs["sas_a.png"], "Sas of A", caption=_cap("A", c.a, "Sas"))
                     + page.image(pngs["sas_b.png"], "Sas of B", caption=_cap("B", c.b, "Sas"))
                     + page.image(pngs["sg_a.png"], "Sg of A", caption=_cap("A", c.a, "Sg"))
                     + page.image(pngs["sg_b.png"], "Sg of B", caption=_cap("B", c.b, "Sg"))
                     + "</div>", anchor="signatures"),
        page.section("Difference of the signatures",
                     '<div class="grid">'
                     + page.image(pngs["difference.png"], "difference of the signatures, B minus A",
                                  caption=_DIFFERENCE_CAPTION)
                     + "</div>", anchor="difference"),
        page.section("Class composition", page.image(pngs["classes.png"], "class composition"),
                     _class_table(sides, ("A", "B")), anchor="classes"),
        page.section("Geometric entropy Egeom", page.image(pngs["egeom.png"], "pdfs of Egeom",
                                                            caption=_EGEOM_CAPTION), anchor="egeom"),
        page.section("Saliency per class", page.image(pngs["saliency_by_class.png"], "class-wise pdfs of Cl, Cs, Cp",
                                                       caption=_SALIENCY_CAPTION), anchor="saliency"),
        page.section("Top views", _top_views(sides, ("A", "B"), pngs, ("top_view_a.png", "top_view_b.png")),
                     anchor="top-views"),
        page.section("Parameters and provenance", provenance, anchor="provenance"),
    ]
    return Report(title, page.fragment(title, _made(), parts), pngs)


def signature_report(side, *, render="smooth"):
    """The :class:`Report` of one cloud (a :class:`lidar_sig.comparison.Side`)."""
    from .. import render as images
    from . import figures

    sig = side.signature
    label = Path(side.name).name
    with step("rendering the report", rendering=render):
        pngs = {"sas.png": images.encode_png(images.signature_image(sig, "sas", render)),
                "sg.png": images.encode_png(images.signature_image(sig, "sg", render)),
                "classes.png": figures.class_composition([sig], [label]),
                "egeom.png": figures.egeom_pdfs([sig], [label]),
                "saliency_by_class.png": figures.saliency_pdfs([sig], [label])}
        if side.result is not None:
            pngs["top_view.png"] = _top_view(side)
    with step("checksums of the inputs"):
        provenance = _provenance((side,), ("",), render)
    title = f"lidar_sig signature: {label}"
    parts = [
        _summary((side,), ("",), None, render=render),
        page.section("Signatures", _signatures_intro(render), _class_legend([sig]),
                     '<div class="grid">'
                     + page.image(pngs["sas.png"], "Sas", caption=_cap("", side, "Sas"))
                     + page.image(pngs["sg.png"], "Sg", caption=_cap("", side, "Sg")) + "</div>",
                     anchor="signatures"),
        page.section("Class composition", page.image(pngs["classes.png"], "class composition"),
                     _class_table((side,), ("",)), anchor="classes"),
        page.section("Geometric entropy Egeom", page.image(pngs["egeom.png"], "pdf of Egeom",
                                                            caption=_EGEOM_CAPTION), anchor="egeom"),
        page.section("Saliency per class", page.image(pngs["saliency_by_class.png"], "class-wise pdfs of Cl, Cs, Cp",
                                                       caption=_SALIENCY_CAPTION), anchor="saliency"),
        page.section("Top view", _top_views((side,), ("",), pngs, ("top_view.png",)), anchor="top-views"),
        page.section("Parameters and provenance", provenance, anchor="provenance"),
    ]
    return Report(title, page.fragment(title, _made(), parts), pngs)


# -- pieces -----------------------------------------------------------------------------------

_DIFFERENCE_CAPTION = (
    "Where in the triangle B has a larger share of its points than A (red), and a smaller one "
    "(blue), per pixel, in the rendering's smoothing; the scale saturates at the 99th percentile "
    "of the differences. Each cloud's points are counted as shares, so a denser survey alone "
    "leaves this image white. Removed vegetation shows as blue towards the point vertex, new "
    "roofs or ground as red towards the surface vertex.")
_EGEOM_CAPTION = (
    "Distribution of the geometric entropy of the points with a defined saliency; d_EMD-Info is the "
    "earth mover's distance between these two curves. Surfaces (ground, roofs) sit near 0 to 0.4, "
    "vegetation and clutter further right.")
_SALIENCY_CAPTION = (
    "Per semantic class, the distribution of each saliency over its points (the paper's figure of "
    "class-wise saliency pdfs). Ground and roofs peak at high Cs; vegetation spreads over Cp; "
    "edges, wires and trunks raise Cl.")


def _made():
    from .. import __version__

    now = datetime.datetime.now().astimezone().strftime("%Y-%m-%d %H:%M %Z")
    return f"made by lidar_sig {page.esc(__version__)} on {page.esc(now)}"


def _summary(sides, tags, comparison, *, render=None):
    lines = []
    for side, tag in zip(sides, tags):
        m = side.signature.metadata
        who = f'<span class="{tag.lower()}">{tag}</span> ' if tag else ""
        what = "archive" if side.result is None else "cloud"
        lines.append(f"<li>{who}<code>{page.esc(side.name)}</code> ({what}, "
                     f"{int(m.get('n_points', side.signature.n_points)):,} points)</li>")
    m = sides[0].signature.metadata
    render = comparison.render if comparison is not None else render
    method = (f"{page.esc(m.get('descriptor', '?'))} {page.esc(m.get('strategy', '?'))}, "
              f"{page.esc(_scales_text(m))}, {page.esc(m.get('weights', '?'))} weights, {page.esc(render)} rendering")
    return f"<ul>{''.join(lines)}</ul><p>Method: {method}.</p>"


def _warnings(warnings):
    if not warnings:
        return '<p class="ok">No warnings: nothing in this run is known to make the figures mislead.</p>'
    items = "".join(f"<li>{page.esc(w)}</li>" for w in warnings)
    return f'<div class="warnings"><ul>{items}</ul></div>'


def _metrics_table(values):
    from ..metrics import METRICS

    rows = []
    for m in METRICS:
        v = values.get(m.key)
        shown = "n/a (needs class labels in both clouds)" if v is None else f"{v:.4f}"
        direction = "larger" if m.larger_differs else "smaller"
        rows.append((f"<b>{page.esc(m.name)}</b>", shown, page.esc(m.range), f"{m.same:g}",
                     direction, page.esc(m.reacts)))
    return page.table(("metric", "value", "range", "identical clouds", "more different when", "reacts to"),
                      rows, numeric=(1, 3), cls="metrics")


def _signatures_intro(render):
    return ("<p>Each point is placed in the triangle by its saliency (Cl, Cs, Cp): line-type points "
            "near the top vertex, surface-type bottom right, point-type (scattered, volumetric) bottom "
            "left. <b>Sas</b> colours each place by the classes of its points; <b>Sg</b> shades it by "
            f"how many points fall there ({page.esc(render)} rendering).</p>")


def _class_legend(signatures):
    from .figures import present_classes

    classes = signatures[0].classes
    items = []
    for k in present_classes(signatures):
        r, g, b = (int(round(c * 255)) for c in classes.class_colors[k])
        items.append(f'<span style="display:inline-block;margin-right:14px"><span style="display:inline-block;'
                     f'width:12px;height:12px;background:rgb({r},{g},{b});border:1px solid #888;'
                     f'vertical-align:-1px"></span> {page.esc(classes.class_names[k])}</span>')
    return f'<p class="muted">Classes: {"".join(items)}</p>' if items else ""


def _cap(tag, side, kind):
    who = f'<span class="{tag.lower()}">{tag}</span> ' if tag else ""
    return f"{who}{kind} of <code>{page.esc(Path(side.name).name)}</code>"


def _class_table(sides, tags):
    classes = sides[0].signature.classes
    totals = [np.asarray(s.signature.class_totals, dtype=np.int64) for s in sides]
    present = [k for k in range(len(classes)) if any(t[k] for t in totals)]
    header = ["class"]
    for tag in tags:
        prefix = f"{tag}: " if tag else ""
        header += [f"{prefix}points", f"{prefix}share"]
    if len(sides) == 2:
        header += ["change of share (B - A)"]
    rows = []
    for k in present:
        row = [page.esc(classes.class_names[k])]
        shares = []
        for t in totals:
            share = t[k] / max(t.sum(), 1) * 100
            shares.append(share)
            row += [f"{int(t[k]):,}", f"{share:.1f}%"]
        if len(sides) == 2:
            row.append(f"{shares[1] - shares[0]:+.1f} points")
        rows.append(row)
    numeric = tuple(range(1, len(header)))
    return page.table(header, rows, numeric=numeric)


def _top_view(side, span=None):
    from ..render import encode_png, top_view_image

    result = side.result
    unit = "m" if result.cloud.units.horizontal == 1.0 else result.cloud.units.name
    with step("top view", points=len(result.cloud)):
        return encode_png(top_view_image(result.cloud.xyz, result.saliency.values, unit=unit, span=span))


def _shared_span(sides):
    """The ground length (coordinate units) both top views draw at full width, so that they share
    one scale and a building looks as large in both; None unless both sides are clouds in the
    same unit."""
    clouds = [s.result.cloud for s in sides if s.result is not None]
    if len(clouds) != 2 or clouds[0].units.horizontal != clouds[1].units.horizontal:
        return None
    return max(float(np.ptp(c.xyz[:, :2], axis=0).max()) for c in clouds)


def _top_views(sides, tags, pngs, names):
    parts = []
    for side, tag, name in zip(sides, tags, names):
        who = f'<span class="{tag.lower()}">{tag}</span> ' if tag else ""
        if name in pngs:
            parts.append(page.image(pngs[name], f"top view of {tag or side.name}",
                                    caption=f"{who}<code>{page.esc(Path(side.name).name)}</code> seen from above: "
                                            "each cell shows the saliency of its highest point as "
                                            "RGB = (Cl, Cs, Cp)"))
        else:
            parts.append(f"<p>{who}<code>{page.esc(side.name)}</code> is a signature archive: it keeps the "
                         "counts of the signature, not the points' coordinates, so it has no top view.</p>")
    return '<div class="grid">' + "".join(parts) + "</div>"


def _scales_text(m):
    values = m.get("resolved_scales") or m.get("scale_values") or []
    if m.get("scale_kind") == "knn":
        return "k " + ", ".join(str(int(v)) for v in values)
    if not values:
        return str(m.get("scales", "?"))
    return "radii " + ", ".join(f"{v:.4g}" for v in values) + " m"


def _crs_name(wkt):
    if not wkt:
        return "none recorded (coordinates taken as metres)"
    try:
        import pyproj

        return pyproj.CRS.from_user_input(wkt).name
    except Exception:  # an unreadable CRS text is shown as it is
        return str(wkt)[:80]


def _files(side):
    """(path, size in bytes, SHA-256) of the side's input file and, for an archive, of the
    clouds it records having been made from."""
    from ..io.hdf5 import sha256_of

    out = []
    path = side.result.cloud.path if side.result is not None else side.name
    if path and Path(path).is_file():
        out.append((str(path), Path(path).stat().st_size, sha256_of(path)))
    if side.result is None:
        import json

        for src in json.loads(side.signature.metadata.get("sources", "[]") or "[]"):
            out.append((f"made from {src.get('path', '?')}", None, src.get("sha256", "?")))
    return out


def _provenance(sides, tags, render):
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
    row("kind", [("cloud" if s.result is not None else "signature archive") for s in sides])
    row("CRS", [page.esc(_crs_name(m.get("crs") or (s.result.cloud.crs if s.result is not None else None)))
                for s, m in zip(sides, metas)])
    row("coordinate units", [page.esc(m.get("units", "?")) for m in metas])
    row("points", [f"{int(m.get('n_points', s.signature.n_points)):,}" for s, m in zip(sides, metas)])
    row("undefined saliency (left out of the signature)",
        [f"{int(m.get('n_undefined', s.signature.n_undefined)):,}" for s, m in zip(sides, metas)])
    row("neighbourhoods capped", [f"{int(m.get('n_capped', 0)):,} (at {int(m.get('max_neighbors', 0))} neighbours)"
                                  for m in metas])
    row("duplicate points (one location each)", [f"{int(m.get('n_duplicates', 0)):,}" for m in metas])
    row("descriptor", [page.esc(f"{m.get('descriptor', '?')} {_params(m.get('descriptor_params'))}".strip())
                       for m in metas])
    row("strategy", [page.esc(m.get("strategy", "?")) for m in metas])
    row("scales", [page.esc(_scales_text(m) + _as_given(m)) for m in metas])
    row("neighbour weights", [page.esc(m.get("weights", "?")) for m in metas])
    row("class table", [page.esc(s.signature.classes.name) for s in sides])
    row("signature frame", [f"{s.signature.frame.size} px, margin {s.signature.frame.margin} px" for s in sides])
    row("rendering", [page.esc(render)] * len(sides))
    row("made with", [page.esc(f"lidar_sig {m.get('lidar_sig_version', __version__)}") for m in metas])
    header = ["", *[f'<span class="{t.lower()}">{t}</span>' if t else "" for t in tags]]
    return page.table(header, rows)


def _params(params):
    if isinstance(params, str):
        import json

        params = json.loads(params or "{}")
    return ", ".join(f"{k}={v}" for k, v in sorted((params or {}).items()))


def _as_given(m):
    if m.get("scale_kind") == "radius" and m.get("scale_units") == "normalized":
        return " (given as normalized " + ", ".join(f"{v:g}" for v in m.get("scale_values", [])) + ")"
    return ""
