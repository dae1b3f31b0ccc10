"""A report as a document: one self-contained HTML page and its figures, shown in a notebook,
saved as a file and the figures as PNG files."""
from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

from ..base.progress import step
from . import _page as page
from ._paths import check_plots_folder, check_report_path

if TYPE_CHECKING:
    from ..base.views import Files


class Figures(dict):
    """{file name: PNG bytes} of a report's figures: a dict that prints in one line (how many,
    their size, the first names) rather than its bytes."""

    def __repr__(self):
        from ..base.views import one_line

        names = ", ".join(list(self)[:4]) + (", ..." if len(self) > 4 else "")
        size = sum(len(v) for v in self.values())
        return one_line(f"<Figures {len(self)} PNG, {size / 1e6:.1f} MB: {names}>")


@dataclass(repr=False)
class Report:
    """An HTML report: ``title``, the page's ``body`` (an HTML fragment with its style) and its
    ``figures`` (file name -> PNG bytes), in the page's order."""

    title: str
    body: str
    figures: dict[str, bytes] = field(default_factory=Figures)
    #: Where the page was last saved (None before), for the notebook card's link.
    path: Path | None = field(default=None, compare=False)

    def __post_init__(self):
        self.figures = Figures(self.figures)

    def __repr__(self):
        from ..base.views import one_line

        return one_line(f"<Report {self.title!r}, {len(self.figures)} figures, {len(self.body) / 1e6:.1f} MB of HTML>")

    def html(self) -> str:
        """The whole page, as text."""
        return page.document(self.title, self.body)

    def _repr_html_(self):
        """A notebook's view: a compact card (the title, the sections, the first figure small,
        a link to the saved page); the full page on demand with :meth:`show`."""
        import re
        from html import unescape

        from ..base.views import card

        sections = [unescape(re.sub(r"<[^>]+>", "", h)) for h in re.findall(r"<h2[^>]*>(.*?)</h2>", self.body)]
        facts = [f"{len(self.figures)} figures, {len(self.body) / 1e6:.1f} MB of HTML",
                 "sections: " + ", ".join(sections) if sections else ""]
        where = (f"saved as {self.path}; " if self.path is not None else "")
        html = card(f"Report: {self.title}", [f for f in facts if f], image=_small(self.figures), width=200,
                    note=f"{where}the full page here: report.show(); as a file: report.save('report.html')")
        if self.path is not None:  # a link JupyterLab opens beside the notebook
            target, name = page.esc(Path(self.path).as_posix()), page.esc(Path(self.path).name)
            html += (f'<div style="font-family:sans-serif;font-size:13px;padding:0 4px 4px">'
                     f'<a href="{target}" target="_blank">open {name}</a></div>')
        return html

    def show(self) -> Page:
        """The full page, for a notebook to show in place (its ``_repr_html_``)."""
        return Page(self.body)

    def save(self, path: str | os.PathLike[str], *, overwrite: bool = False) -> None:
        """Write the page to ``path`` (.html), atomically; refuses an existing file unless
        ``overwrite``."""
        from ..io.atomic import atomic_output

        check_report_path(path)
        with step(f"writing {Path(path).name}"), atomic_output(path, overwrite=overwrite) as tmp:
            tmp.write_text(self.html(), encoding="utf-8")
        self.path = Path(path)

    def save_plots(self, folder: str | Path, *, overwrite: bool = False) -> Files:
        """Write every figure as a PNG file in ``folder`` (made if missing, its parent must
        exist); refuses existing files unless ``overwrite``. Returns the paths written (a list
        that prints in one line)."""
        from ..io.png import write_png
        from ..base.views import Files

        folder = Path(folder)
        check_plots_folder(folder, self.figures, overwrite=overwrite)
        folder.mkdir(exist_ok=True)
        paths = []
        with step(f"writing {len(self.figures)} plots in {folder}"):
            for name, png in self.figures.items():
                write_png(folder / name, png, overwrite=overwrite)
                paths.append(folder / name)
        return Files(paths)


@dataclass(repr=False)
class Page:
    """A report's full page shown in a notebook (:meth:`Report.show`)."""

    body: str

    def __repr__(self):
        return f"<Page of a report, {len(self.body) / 1e6:.1f} MB of HTML>"

    def _repr_html_(self):
        return self.body


def _small(figures, width=200):
    """(H, W, 3) uint8: the first figure scaled to ``width`` px, or None without figures."""
    if not figures:
        return None
    import cv2
    import numpy as np

    image = cv2.imdecode(np.frombuffer(next(iter(figures.values())), np.uint8), cv2.IMREAD_COLOR)
    if image is None:
        return None
    height = max(1, round(image.shape[0] * width / image.shape[1]))
    return cv2.resize(image, (width, height), interpolation=cv2.INTER_AREA)[:, :, ::-1]
