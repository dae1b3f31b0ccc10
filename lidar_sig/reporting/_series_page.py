"""The HTML report of a change series (three epochs or more): the map of the interval in which
each cell changed most, then each interval's map and most changed cells."""
from __future__ import annotations

from pathlib import Path

from ..base.errors import counted
from ..base.progress import step
from . import _page as page
from ._changes_page import cells_table, settings_text
from ._document import Report
from .map_image import TOP, change_map_image, when_map_image
from .sections import made_line, warnings_list


def series_report(series, *, top=TOP):
    """The :class:`Report` of a computed :class:`lidar_sig.change_map.ChangeSeries`."""
    from .render import encode_png

    pngs = {}
    with step("rendering the report", intervals=len(series.maps)):
        pngs["when.png"] = encode_png(when_map_image(series))
        for k, cm in enumerate(series.maps, 1):
            pngs[f"interval{k}.png"] = encode_png(change_map_image(cm, top=top))
    names = [Path(e.name).name for e in series.epochs]
    title = f"lidar_sig change series: {', '.join(names)}"
    epochs = "".join(f"<li>E{k} <code>{page.esc(e.name)}</code> ({counted(len(e.cloud), 'point')})</li>"
                     for k, e in enumerate(series.epochs, 1))
    warnings = list(dict.fromkeys(w for cm in series.maps for w in cm.warnings))
    parts = [f"<ul>{epochs}</ul><p>Epochs in time order; each interval compares two consecutive epochs on one "
             "grid, each epoch's saliency computed once.</p>",
             page.section("Warnings", warnings_list(warnings), anchor="warnings"),
             page.section("When", page.image(pngs["when.png"], "when each cell changed most",
                                             caption="The interval in which each cell changed most: the one "
                                                     "where it lies farthest above its level of detection "
                                                     "(largest lod_ratio) among the intervals where it changed "
                                                     "significantly."), anchor="when")]
    for k, cm in enumerate(series.maps):
        parts.append(page.section(series.interval_name(k).capitalize(), settings_text(cm),
                                  page.image(pngs[f"interval{k + 1}.png"], f"change map of interval {k + 1}",
                                             caption=f"<code>{page.esc(names[k])}</code> -> <code>"
                                                     f"{page.esc(names[k + 1])}</code>: each cell in its colour "
                                                     "on the change scale, the same on every map"),
                                  cells_table(cm, top), anchor=f"interval{k + 1}"))
    return Report(title, page.fragment(title, made_line(), parts), pngs)
