"""Pieces the report pages share: the summary of the inputs, the warnings, the table of metrics,
the introduction and legend of the signatures, figure captions, the class table and the top
views; each returns an HTML fragment (:mod:`lidar_sig.reporting._page`)."""
from __future__ import annotations

import datetime
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from ..method.cloud import kept_points
from ..base.progress import step
from ..method.scales import recorded_kind
from . import _page as page

EGEOM_CAPTION = (
    "Distribution of the geometric entropy of the points with a defined saliency, one curve per cloud; "
    "d_EMD-Info is the earth mover's distance between the two clouds' curves. Surfaces (ground, roofs) "
    "sit near 0 to 0.4, vegetation and clutter further right.")
#: The same of one cloud's report: one curve.
EGEOM_CAPTION_ONE = (
    "Distribution of the geometric entropy of the cloud's points with a defined saliency; compared with "
    "another cloud, d_EMD-Info is the earth mover's distance between this curve and the other's. Surfaces "
    "(ground, roofs) sit near 0 to 0.4, vegetation and clutter further right.")
SALIENCY_CAPTION = (
    "Per semantic class, the distribution of each saliency over its points (the paper's figure of "
    "class-wise saliency pdfs). Ground and roofs peak at high Cs; vegetation spreads over Cp; "
    "edges, wires and trunks raise Cl.")


def made_line():
    """The line under the title: the version of lidar_sig and the time the report was made."""
    from .. import __version__

    now = datetime.datetime.now().astimezone().strftime("%Y-%m-%d %H:%M %Z")
    return f"made by lidar_sig {page.esc(__version__)} on {page.esc(now)}"


def summary(sides, tags, comparison, *, render=None):
    """The inputs (name, kind, points) and the method, under the title."""
    lines = []
    for side, tag in zip(sides, tags):
        m = side.signature.metadata
        who = f'<span class="{tag.lower()}">{tag}</span> ' if tag else ""
        what = side.kind
        lines.append(f"<li>{who}<code>{page.esc(side.name)}</code> ({what}, "
                     f"{int(m.get('n_points', side.signature.n_points)):,} points)</li>")
    m = sides[0].signature.metadata
    render = comparison.render if comparison is not None else render
    method = (f"{page.esc(m.get('descriptor', '?'))} {page.esc(m.get('strategy', '?'))}, "
              f"{page.esc(scales_text(m))}, {page.esc(m.get('weights', '?'))} weights, {page.esc(render)} rendering")
    return f"<ul>{''.join(lines)}</ul><p>Method: {method}.</p>"


def warnings_list(warnings):
    """The run's warnings, or that there are none."""
    if not warnings:
        return '<p class="ok">No warnings: nothing in this run is known to make the figures mislead.</p>'
    items = "".join(f"<li>{page.esc(w)}</li>" for w in warnings)
    return f'<div class="warnings"><ul>{items}</ul></div>'


#: How the metrics table's scale column was measured.
SCALE_CAPTION = ("<p class=\"muted\">On the scale: what the value is most like among the values the project "
                 "measured with the default method between each of 7 reference tiles (IGN LiDAR HD, AHN3, ISPRS) "
                 "and itself rotated, a random 80% or 60% of its points, its adjacent tile and a tile of another "
                 "city (docs/comparison.md); the range is that case's lowest to highest value.</p>")


def metrics_table(values):
    """The metrics' values with their ranges, what each reacts to and where each stands among the
    values the project measured (:data:`lidar_sig.metrics.METRICS`, :meth:`Metric.place`)."""
    from ..metrics import METRICS

    rows = []
    for m in METRICS:
        v = values.get(m.key)
        shown = "n/a (needs class labels in both clouds)" if v is None else f"{v:.4f}"
        scale = "&ndash;" if v is None else page.esc(m.place(v)[1])
        direction = "larger" if m.larger_differs else "smaller"
        rows.append((f"<b>{page.esc(m.name)}</b>", shown, scale, page.esc(m.range), f"{m.same:g}",
                     direction, page.esc(m.reacts)))
    return page.table(("metric", "value", "on the project's scale", "range", "identical clouds",
                       "more different when", "reacts to"), rows, numeric=(1, 4), cls="metrics") + SCALE_CAPTION


def signatures_intro(render):
    """How to read Sg and Sas."""
    return ("<p>Each point is placed in the triangle by its saliency (Cl, Cs, Cp): line-type points "
            "near the top vertex, surface-type bottom right, point-type (scattered, volumetric) bottom "
            "left. <b>Sas</b> colours each place by the classes of its points; <b>Sg</b> shades it by "
            f"how many points fall there ({page.esc(render)} rendering).</p>")


def class_legend(signatures):
    """The colours of the classes present in ``signatures``."""
    from ._figures import present_classes

    classes = signatures[0].classes
    items = []
    for k in present_classes(signatures):
        r, g, b = (int(round(c * 255)) for c in classes.class_colors[k])
        items.append(f'<span style="display:inline-block;margin-right:14px"><span style="display:inline-block;'
                     f'width:12px;height:12px;background:rgb({r},{g},{b});border:1px solid #888;'
                     f'vertical-align:-1px"></span> {page.esc(classes.class_names[k])}</span>')
    return f'<p class="muted">Classes: {"".join(items)}</p>' if items else ""


def figure_caption(tag, side, kind):
    """Caption of the signature ``kind`` (Sg or Sas) of a side tagged ``tag`` (A, B or none)."""
    who = f'<span class="{tag.lower()}">{tag}</span> ' if tag else ""
    return f"{who}{kind} of <code>{page.esc(Path(side.name).name)}</code>"


def class_table(sides, tags):
    """Points and share of each class per side and, for two, the change of share."""
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


def top_view(side, span=None):
    """PNG of the side's cloud seen from above, coloured by its saliency (``span``: see
    :func:`shared_span`)."""
    from .render import encode_png, top_view_image

    result = side.result
    cloud = result.cloud
    unit = "m" if cloud.units.horizontal == 1.0 else cloud.units.name
    # the points the run used: withheld and noise points (high noise above the roofs) would be
    # drawn grey over the scene
    noise = None if result.metadata.get("keep_noise") else result.signature.classes.noise
    kept = kept_points(cloud.labels, cloud.withheld, noise)
    xyz, values = (cloud.xyz, result.saliency.values) if kept is None else \
        (cloud.xyz[kept], result.saliency.values[kept])
    with step("top view", points=len(xyz)):
        return encode_png(top_view_image(xyz, values, unit=unit, span=span))


def shared_span(sides):
    """The ground length (coordinate units) both top views draw at full width, so that they share
    one scale and a building looks as large in both; None unless both sides are clouds in the
    same unit."""
    clouds = [s.result.cloud for s in sides if s.result is not None]
    if len(clouds) != 2 or clouds[0].units.horizontal != clouds[1].units.horizontal:
        return None
    return max(float(np.ptp(c.xyz[:, :2], axis=0).max()) for c in clouds)


def top_views(sides, tags, pngs, names):
    """The top views of the sides (an archive has none, and the page says why)."""
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


def scales_text(m: Mapping[str, Any]) -> str:
    """The scales of recorded metadata ``m`` for people: k values, or radii in metres."""
    values = m.get("resolved_scales") or m.get("scale_values") or []
    kind = recorded_kind(m)
    if kind is None or not values:
        return str(m.get("scales", "?"))
    return kind.describe(values)
