"""The report's plots, drawn with matplotlib and returned as PNG bytes: the pdfs of Egeom, the
class-wise pdfs of Cl, Cs and Cp (the paper's figure of class-wise saliency pdfs), the class
composition of each cloud, and a survey's maps: tile footprints coloured by outlier score and the
tiles placed by likeness (MDS).

Figures are made through ``matplotlib.figure.Figure`` (no pyplot, no global backend), so a
notebook's own plots are untouched; matplotlib is imported only when a report is made.
The signatures' plots take the signatures to draw (one or two) and their names.
"""
from __future__ import annotations

import io

import numpy as np

from ..method.saliency_map import LN3

#: Line colours of the first and second cloud, the ends of the difference image's ramp.
SIDE_COLOURS = ("#2166ac", "#b2182b")
#: Bins of the class-wise saliency pdfs over [0, 1].
SALIENCY_BINS = 50
DPI = 100


def _figure(width, height, layout="constrained"):
    from matplotlib.figure import Figure

    fig = Figure(figsize=(width, height), dpi=DPI, layout=layout)
    fig.set_facecolor("white")
    return fig


def _png(fig):
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png", dpi=DPI)
    return buffer.getvalue()


def egeom_pdfs(signatures, names):
    """Pdfs of Egeom (nats) of each signature, overlaid (docs/method.md, "Metrics", d_EMD-Info compares them)."""
    fig = _figure(7.5, 3.2)
    ax = fig.subplots()
    for sig, name, colour in zip(signatures, names, SIDE_COLOURS):
        counts = np.asarray(sig.egeom_counts, dtype=np.float64)
        edges = np.linspace(0.0, LN3, len(counts) + 1)
        pdf = counts / max(counts.sum(), 1.0) / np.diff(edges)
        ax.stairs(pdf, edges, color=colour, linewidth=1.6, label=name)
    ax.set_xlim(0.0, LN3)
    ax.set_xlabel("Egeom, geometric entropy (nats): 0 = purely line-, surface- or point-type, ln 3 = equal mix")
    ax.set_ylabel("probability density (1/nat)")
    ax.grid(alpha=0.3)
    ax.legend(frameon=False, fontsize=9)
    return _png(fig)


def present_classes(signatures):
    """Indices of the classes holding defined points in any signature, the most common first."""
    counts = np.sum([s.class_counts for s in signatures], axis=0)
    order = np.argsort(-counts, kind="stable")
    return [int(k) for k in order if counts[k] > 0]


def saliency_pdfs(signatures, names, *, bins=SALIENCY_BINS):
    """Per semantic class (rows), the pdfs of Cl, Cs and Cp (columns) of each signature: the
    paper's figure of class-wise saliency pdfs, from the count rasters (so archives have it)."""
    from ..io.archive import saliency_histograms

    classes = signatures[0].classes
    rows = present_classes(signatures)
    hists = [saliency_histograms(s, bins=bins) for s in signatures]
    height = 0.9 + 1.55 * max(len(rows), 1)
    fig = _figure(9.0, height, layout=None)  # fixed margins: a constrained layout of many axes is slow
    axes = fig.subplots(max(len(rows), 1), 3, sharex=True, squeeze=False)
    fig.subplots_adjust(left=0.09, right=0.98, top=1 - 0.55 / height, bottom=0.45 / height, wspace=0.18,
                        hspace=0.22)
    edges = np.linspace(0.0, 1.0, bins + 1)
    for r, k in enumerate(rows):
        for c, label in enumerate(("Cl (line)", "Cs (surface)", "Cp (point)")):
            ax = axes[r, c]
            for h, name, colour in zip(hists, names, SIDE_COLOURS):
                counts = h[k, c].astype(np.float64)
                if counts.sum() > 0:
                    ax.stairs(counts / counts.sum() / np.diff(edges), edges, color=colour, linewidth=1.3,
                              label=name)
            ax.set_xlim(0.0, 1.0)
            ax.tick_params(labelsize=8)
            ax.grid(alpha=0.3)
            if r == 0:
                ax.set_title(label, fontsize=10)
            if r == len(rows) - 1:
                ax.set_xlabel(label.split()[0], fontsize=9)
        name = classes.class_names[k]
        colour = tuple(classes.class_colors[k])
        axes[r, 0].set_ylabel(name, fontsize=9, color="black",
                              bbox=dict(boxstyle="round,pad=0.25", facecolor=colour, alpha=0.35, linewidth=0))
    if rows:
        axes[0, 2].legend(frameon=False, fontsize=8, loc="upper right")
    fig.suptitle("probability density of each saliency, per class", fontsize=10)
    return _png(fig)


def class_composition(signatures, names):
    """Share of each class among all labelled points (defined saliency or not, as delta_KL and
    L1 count them), one bar per cloud, in the class colours."""
    classes = signatures[0].classes
    totals = [np.asarray(s.class_totals, dtype=np.float64) for s in signatures]
    shares = [t / max(t.sum(), 1.0) * 100 for t in totals]
    present = [k for k in np.argsort(-np.sum(shares, axis=0), kind="stable") if np.sum(shares, axis=0)[k] > 0]
    n = len(signatures)
    fig = _figure(7.5, 0.8 + 0.42 * n * max(len(present), 1))
    ax = fig.subplots()
    height = 0.8 / n
    y = np.arange(len(present), dtype=np.float64)
    for i, (share, name) in enumerate(zip(shares, names)):
        pos = y + (i - (n - 1) / 2) * height
        colours = [tuple(classes.class_colors[k]) for k in present]
        bars = ax.barh(pos, [share[k] for k in present], height=height * 0.92, color=colours,
                       edgecolor=SIDE_COLOURS[i], linewidth=1.2, hatch="//" if i == 1 else None)
        for bar, k in zip(bars, present):
            ax.text(bar.get_width() + 0.5, bar.get_y() + bar.get_height() / 2, f"{share[k]:.1f}%",
                    va="center", fontsize=8, color=SIDE_COLOURS[i])
        ax.barh([np.nan], [0], color="white", edgecolor=SIDE_COLOURS[i], linewidth=1.2,
                hatch="//" if i == 1 else None, label=name)
    ax.set_yticks(y, [classes.class_names[k] for k in present], fontsize=9)
    ax.invert_yaxis()
    ax.set_xlabel("share of the labelled points (%)")
    ax.set_xlim(0, max(max(s.max() for s in shares) * 1.15, 1.0))
    ax.grid(axis="x", alpha=0.3)
    if n > 1:
        ax.legend(frameon=False, fontsize=9, loc="lower right")
    return _png(fig)


#: Colour map of outlier scores (low to high) in the survey's plots.
SCORE_CMAP = "viridis"


def footprint_map(polygons, scores, labels, *, title=None, unit="m"):
    """Tile footprints (``polygons``: (K, 2) arrays in one CRS) filled by ``scores`` on one
    colour scale with its bar, and ``labels`` (text or None per tile) written at their centres:
    the map of a survey's outlier scores."""
    from matplotlib.collections import PolyCollection

    allxy = np.concatenate([np.asarray(p, np.float64) for p in polygons])
    span = np.ptp(allxy, axis=0)
    aspect = float(span[1] / span[0]) if span[0] > 0 else 1.0
    width = 7.5
    fig = _figure(width, min(max(width * aspect, 2.5), 10.0))
    ax = fig.subplots()
    scores = np.asarray(scores, np.float64)
    coll = PolyCollection([np.asarray(p) for p in polygons], array=scores, cmap=SCORE_CMAP, edgecolors="#333333",
                          linewidths=0.4, alpha=0.9)
    ax.add_collection(coll)
    for poly, label in zip(polygons, labels):
        if label:
            x, y = np.asarray(poly, np.float64).mean(axis=0)
            ax.text(x, y, label, ha="center", va="center", fontsize=8, color="white",
                    bbox=dict(boxstyle="round,pad=0.2", facecolor="black", alpha=0.6, linewidth=0))
    ax.set_xlim(allxy[:, 0].min(), allxy[:, 0].max())
    ax.set_ylim(allxy[:, 1].min(), allxy[:, 1].max())
    ax.set_aspect("equal")
    ax.ticklabel_format(useOffset=False, style="plain")
    ax.tick_params(labelsize=8)
    ax.set_xlabel(f"x ({unit})", fontsize=9)
    ax.set_ylabel(f"y ({unit})", fontsize=9)
    if title:
        ax.set_title(title, fontsize=10)
    fig.colorbar(coll, ax=ax, label="outlier score (robust z)", shrink=0.8)
    return _png(fig)


def likeness_map(xy, scores, labels):
    """Tiles as points of a 2-D embedding of their distances (classical MDS), coloured by
    ``scores``, with ``labels`` (text or None per tile) beside the points."""
    fig = _figure(7.5, 5.5)
    ax = fig.subplots()
    xy = np.asarray(xy, np.float64)
    dots = ax.scatter(xy[:, 0], xy[:, 1], c=scores, cmap=SCORE_CMAP, s=28, edgecolors="#333333", linewidths=0.4)
    for (x, y), label in zip(xy, labels):
        if label:
            ax.annotate(label, (x, y), xytext=(4, 4), textcoords="offset points", fontsize=8)
    ax.set_xlabel("MDS axis 1 (distance units)", fontsize=9)
    ax.set_ylabel("MDS axis 2", fontsize=9)
    ax.set_aspect("equal", adjustable="datalim")
    ax.grid(alpha=0.3)
    fig.colorbar(dots, ax=ax, label="outlier score (robust z)", shrink=0.8)
    return _png(fig)
