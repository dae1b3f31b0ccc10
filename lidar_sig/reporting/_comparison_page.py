"""The report of a comparison: Sg and Sas of both clouds in the same frame and the difference of
the two signatures, the metrics with what each reacts to, the run's warnings, the pdfs of Egeom,
the class-wise pdfs of Cl, Cs and Cp, the class composition, a top view of each cloud coloured
by its saliency, and the parameters and provenance of the run."""
from __future__ import annotations

from pathlib import Path

from ..base.progress import step
from . import _page as page
from ._document import Report
from ._provenance import provenance
from .sections import (EGEOM_CAPTION, SALIENCY_CAPTION, class_legend, class_table, figure_caption, made_line,
                       metrics_table, shared_span, signatures_intro, summary, top_view, top_views, warnings_list)

#: File names of the comparison report's figures (``save_plots``), in the page's order.
COMPARISON_PLOTS = ("sas_a.png", "sas_b.png", "sg_a.png", "sg_b.png", "difference.png", "classes.png",
                    "egeom.png", "saliency_by_class.png", "top_view_a.png", "top_view_b.png")

DIFFERENCE_CAPTION = (
    "Where in the triangle B has a larger share of its points than A (red), and a smaller one "
    "(blue), per pixel, in the rendering's smoothing; the scale saturates at the 99th percentile "
    "of the differences. Each cloud's points are counted as shares, so a denser survey alone "
    "leaves this image white. Removed vegetation shows as blue towards the point vertex, new "
    "roofs or ground as red towards the surface vertex.")


def comparison_report(comparison):
    """The :class:`Report` of a computed :class:`lidar_sig.comparison.Comparison`."""
    from . import render as images
    from . import _figures as figures

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
        span = shared_span(sides)
        for side, tag in zip(sides, "ab"):
            if side.result is not None:
                pngs[f"top_view_{tag}.png"] = top_view(side, span)
    with step("checksums of the inputs"):
        table = provenance(sides, ("A", "B"), c.render)
    title = f"lidar_sig comparison: {Path(c.a.name).name} and {Path(c.b.name).name}"
    parts = [
        summary(sides, ("A", "B"), c),
        page.section("Warnings", warnings_list(c.warnings), anchor="warnings"),
        page.section("Metrics", metrics_table(c.metrics), anchor="metrics"),
        page.section("Signatures", signatures_intro(c.render), class_legend(sigs),
                     '<div class="grid">'
                     + page.image(pngs["sas_a.png"], "Sas of A", caption=figure_caption("A", c.a, "Sas"))
                     + page.image(pngs["sas_b.png"], "Sas of B", caption=figure_caption("B", c.b, "Sas"))
                     + page.image(pngs["sg_a.png"], "Sg of A", caption=figure_caption("A", c.a, "Sg"))
                     + page.image(pngs["sg_b.png"], "Sg of B", caption=figure_caption("B", c.b, "Sg"))
                     + "</div>", anchor="signatures"),
        page.section("Difference of the signatures",
                     '<div class="grid">'
                     + page.image(pngs["difference.png"], "difference of the signatures, B minus A",
                                  caption=DIFFERENCE_CAPTION)
                     + "</div>", anchor="difference"),
        page.section("Class composition", page.image(pngs["classes.png"], "class composition"),
                     class_table(sides, ("A", "B")), anchor="classes"),
        page.section("Geometric entropy Egeom", page.image(pngs["egeom.png"], "pdfs of Egeom",
                                                            caption=EGEOM_CAPTION), anchor="egeom"),
        page.section("Saliency per class", page.image(pngs["saliency_by_class.png"], "class-wise pdfs of Cl, Cs, Cp",
                                                       caption=SALIENCY_CAPTION), anchor="saliency"),
        page.section("Top views", top_views(sides, ("A", "B"), pngs, ("top_view_a.png", "top_view_b.png")),
                     anchor="top-views"),
        page.section("Parameters and provenance", table, anchor="provenance"),
    ]
    return Report(title, page.fragment(title, made_line(), parts), pngs)
