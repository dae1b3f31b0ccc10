"""The report of one cloud: its Sg and Sas, the pdf of Egeom, the class-wise pdfs of Cl, Cs and
Cp, the class composition, a top view coloured by its saliency, and the parameters and
provenance of the run."""
from __future__ import annotations

from pathlib import Path

from ..base.progress import step
from . import _page as page
from ._document import Report
from ._provenance import provenance
from .sections import (EGEOM_CAPTION_ONE, SALIENCY_CAPTION, class_legend, class_table, figure_caption, made_line,
                       signatures_intro, summary, top_view, top_views)

#: File names of the single-cloud report's figures.
SIGNATURE_PLOTS = ("sas.png", "sg.png", "classes.png", "egeom.png", "saliency_by_class.png", "top_view.png")


def signature_report(side, *, render="smooth"):
    """The :class:`Report` of one cloud: a :class:`lidar_sig.comparison.Side` (its name, its
    signature and, for a cloud, the pipeline Result)."""
    from . import render as images
    from . import _figures as figures

    sig = side.signature
    label = Path(side.name).name
    with step("rendering the report", rendering=render):
        pngs = {"sas.png": images.encode_png(images.signature_image(sig, "sas", render)),
                "sg.png": images.encode_png(images.signature_image(sig, "sg", render)),
                "classes.png": figures.class_composition([sig], [label]),
                "egeom.png": figures.egeom_pdfs([sig], [label]),
                "saliency_by_class.png": figures.saliency_pdfs([sig], [label])}
        if side.result is not None:
            pngs["top_view.png"] = top_view(side)
    with step("checksums of the inputs"):
        table = provenance((side,), ("",), render)
    title = f"lidar_sig signature: {label}"
    parts = [
        summary((side,), ("",), None, render=render),
        page.section("Signatures", signatures_intro(render), class_legend([sig]),
                     '<div class="grid">'
                     + page.image(pngs["sas.png"], "Sas", caption=figure_caption("", side, "Sas"))
                     + page.image(pngs["sg.png"], "Sg", caption=figure_caption("", side, "Sg")) + "</div>",
                     anchor="signatures"),
        page.section("Class composition", page.image(pngs["classes.png"], "class composition"),
                     class_table((side,), ("",)), anchor="classes"),
        page.section("Geometric entropy Egeom", page.image(pngs["egeom.png"], "pdf of Egeom",
                                                            caption=EGEOM_CAPTION_ONE), anchor="egeom"),
        page.section("Saliency per class", page.image(pngs["saliency_by_class.png"], "class-wise pdfs of Cl, Cs, Cp",
                                                       caption=SALIENCY_CAPTION), anchor="saliency"),
        page.section("Top view", top_views((side,), ("",), pngs, ("top_view.png",)), anchor="top-views"),
        page.section("Parameters and provenance", table, anchor="provenance"),
    ]
    return Report(title, page.fragment(title, made_line(), parts), pngs)
