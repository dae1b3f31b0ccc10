"""More than two epochs: a change map per interval (each consecutive pair of epochs, on one grid,
each epoch's saliency computed once) and, per cell, the interval in which it changed most."""
from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ..base.errors import LidarSigError, as_path, whole_number
from ..base.progress import step

if TYPE_CHECKING:
    from ..reporting import Report
    from ._grid import Grid

#: Value of the "when" band in a cell compared in some interval but never significant.
NEVER = 0
#: Why a series writes no points with their cell's change (the job refuses it before the work).
POINTS_OF_TWO = ("the points with their cell's change are written for two epochs; run changes on the two epochs "
                 "of the interval you want them for")


@dataclass(repr=False)
class ChangeSeries:
    """The result of :func:`lidar_sig.change_map.changes` for three epochs or more.

    ``maps[k]`` is the :class:`~lidar_sig.change_map.ChangeMap` of interval k + 1 (epoch k + 1
    to epoch k + 2, 1-based as printed); all share one grid, one score metric and the epochs'
    saliency (``epochs``, in time order).
    """

    maps: list
    epochs: list
    #: What was read when the epochs were clipped to an area of interest (lidar_sig.io.clip.Reading), or None.
    reading: Any = None

    def __repr__(self):
        from ..base.views import one_line

        counts = ", ".join(str(m.n_significant) for m in self.maps)
        most = self.when_counts()
        when = ", ".join(f"{k} {most[str(k)]}" for k in range(1, len(self.maps) + 1))
        return one_line(f"<ChangeSeries {len(self.epochs)} epochs, {len(self.maps)} intervals, {self.grid.rows} x "
                        f"{self.grid.cols} cells; significant per interval: {counts}; changed most in interval: {when}>")

    def _repr_html_(self):
        """A notebook's view: the series (epochs, intervals, cells), the picture of :meth:`when`,
        then each interval's map card."""
        from ..reporting.map_image import INTERVAL_NAMES
        from ..base.views import card

        m = self.maps[0]
        colours = ", ".join(f"{k + 1} {INTERVAL_NAMES[k % len(INTERVAL_NAMES)]}" for k in range(len(self.maps)))
        most = self.when_counts()
        compared = int(np.isfinite(self.when()).sum())
        facts = [" -> ".join(Path(e.name).name for e in self.epochs),
                 f"{len(self.epochs)} epochs, {len(self.maps)} intervals, {self.grid.rows} x {self.grid.cols} cells of "
                 f"{m.cell:g} m; score {self.score} at {m.confidence:.0%}",
                 f"when: {compared:,} cells compared in some interval, {most[str(NEVER)]:,} never significant"]
        rows = [(k + 1, self.interval_name(k).split(" ", 2)[2].strip("()"), int(mk.table["valid"].sum()),
                 mk.n_significant, most[str(k + 1)]) for k, mk in enumerate(self.maps)]
        head = card("ChangeSeries", facts, header=("interval", "epochs", "compared", "significant", "changed most"),
                    rows=rows, numeric=(0, 2, 3, 4), image=self.when_thumbnail(), width=220,
                    note=f"picture (when): each cell in the colour of the interval in which it changed most "
                         f"({colours}); white: compared, never significant; slate: never compared")
        return head + "".join(mk._card(f"ChangeMap of {self.interval_name(k)}") for k, mk in enumerate(self.maps))

    def when_counts(self) -> dict[str, int]:
        """{"0": cells compared but never significant, "1": cells that changed most in interval
        1, ...}: the cells per value of :meth:`when` (as ``to_dict``'s ``when``)."""
        when = self.when()
        return {str(k): int((when == k).sum()) for k in range(NEVER, len(self.maps) + 1)}

    def when_thumbnail(self, size: int = 240) -> np.ndarray:
        """(H, W, 3) RGB picture of :meth:`when`, about ``size`` pixels on its longer side: each
        cell in the colour of its interval (the report's), white where compared but never
        significant, in the colour of "too few points" of the change scale where never compared
        (row 0 north)."""
        from ..reporting.change_scale import CHANGE_SCALE
        from ..reporting.map_image import INTERVALS

        when = self.when()
        index = np.clip(np.nan_to_num(when).astype(int) - 1, 0, None) % len(INTERVALS)
        rgb = np.where((np.nan_to_num(when) > 0)[..., None], INTERVALS[index] / 255.0, 1.0)
        rgb[np.isnan(when)] = np.asarray(CHANGE_SCALE.states["too few points"][0]) / 255.0
        k = max(1, size // max(self.grid.rows, self.grid.cols))
        return np.repeat(np.repeat(rgb, k, axis=0), k, axis=1)

    @property
    def grid(self) -> Grid:
        return self.maps[0].grid

    @property
    def score(self) -> str:
        return self.maps[0].score

    def interval_name(self, k: int) -> str:
        """``"interval 1 (E1 -> E2)"`` for ``k`` = 0, with the epochs' file names."""
        k = whole_number(k, "the interval (counted from 0)", high=len(self.maps) - 1)
        a, b = (Path(e.name).name for e in (self.epochs[k], self.epochs[k + 1]))
        return f"interval {k + 1} ({a} -> {b})"

    def when(self) -> np.ndarray:
        """(rows, cols) float, row 0 north: the interval (1-based) in which each cell changed
        most, i.e. the one where it lies farthest above its level of detection (largest
        ``lod_ratio``, the quantity the cells are ranked and coloured by) among the intervals
        where it changed significantly; :data:`NEVER` (0) where it was compared but never
        significant; NaN where it was never compared."""
        return self._when().reshape(self.grid.rows, self.grid.cols)

    def _when(self) -> np.ndarray:
        """(cells,) :meth:`when` in the table's (row-major) order."""
        valid = np.array([m.table["valid"] for m in self.maps])
        significant = np.array([m.table["significant"] for m in self.maps])
        ratio = np.array([np.where(s, m.table["lod_ratio"], -np.inf) for m, s in zip(self.maps, significant)])
        out = np.where(significant.any(axis=0), np.argmax(ratio, axis=0) + 1.0, float(NEVER))
        return np.where(valid.any(axis=0), out, np.nan)

    def raster(self) -> np.ndarray:
        """(rows, cols) raster of :meth:`when`, row 0 north (the same array)."""
        return self.when()

    def to_dict(self, n: int = 10) -> dict[str, Any]:
        """One entry per interval (its settings, survey parts and ``n`` top cells, as
        :meth:`ChangeMap.to_dict`), and the cells per value of "when"."""
        counts = self.when_counts()
        first = self.maps[0].settings()
        shared = {k: first[k] for k in ("cell_m", "cell_rule", "cell_crs_units", "units", "crs", "min_points",
                                        "min_points_rule", "score", "confidence", "render", "frame_px", "method")}
        grid = {k: first["grid"][k] for k in ("rows", "cols", "transform", "cells")}
        intervals = []
        for k, m in enumerate(self.maps):
            d = m.to_dict(n)
            intervals.append({"interval": k + 1, **{key: d[key] for key in ("a", "b", "density", "coverage",
                                                                              "levels", "warnings", "top")},
                              "valid": d["grid"]["valid"], "significant": d["grid"]["significant"],
                              "changed": d["grid"]["changed"], "false_flags": d["grid"]["false_flags"],
                              "wide_because": d["wide_because"]})
        return {"epochs": [e.name for e in self.epochs], **shared, "grid": grid, "intervals": intervals,
                "when": {"cells": counts, "never_significant": NEVER, "meaning": "the interval (1-based) in which "
                         "the cell changed most; 0 compared but never significant"}}

    def save(self, path: str | os.PathLike[str], *, overwrite: bool = False) -> None:
        """Write by extension: ``.tif``/``.tiff`` every interval's bands (as a change map's,
        described "[k] ...", their meaning "interval k (Ek -> Ek+1): ...") then "when", with its QGIS style beside it
        (``.qml``: "when" in one colour per interval); ``.gpkg`` the cells of each interval, a
        layer each named by its interval
        (``cells_A_to_B``, ``cells_B_to_C``, ...: :func:`~._layers.interval_layer_names`); ``.png`` the map of "when"; ``.html`` the
        report with each interval's map."""
        from ..io import output_group
        from ..io.formats import IMAGE, POINTS, RASTER, REPORT, VECTOR, format_of

        fmt = format_of(as_path(path, "saving a change series"))
        holds = set(fmt.holds) if fmt is not None else set()
        if POINTS in holds:
            raise LidarSigError(POINTS_OF_TWO, path=path)
        if VECTOR in holds:
            from ..io.geopackage import write_geopackage
            from ._layers import cells_layer, interval_layer_names

            with step(f"writing {Path(path).name}", intervals=len(self.maps)):
                write_geopackage(path, [cells_layer(m, name) for m, name in zip(self.maps, interval_layer_names(self))],
                                 overwrite=overwrite)
            return
        if RASTER in holds:
            from ..io.geotiff import write_geotiff
            from ..io.styles import style_path, write_style
            from ._layers import when_style

            rasters, descriptions, meanings = [], [], []
            for k, m in enumerate(self.maps):
                r, d, long = m.bands(prefix=f"[{k + 1}] ", meaning_prefix=f"{self.interval_name(k)}: ")
                rasters += r
                descriptions += d
                meanings += long
            rasters.append(self.raster())
            descriptions.append(f"when: the interval that changed most ({NEVER}: none)")
            meanings.append(f"when: the interval (1 to {len(self.maps)}) in which the cell changed most "
                            f"(largest z among its significant intervals); {NEVER} compared but never significant")
            tags = {k: v for k, v in self.maps[0].metadata_tags().items() if not k.startswith(("epoch", "compared",
                                                                                               "significant"))}
            tags.update({f"epoch_{k + 1}": e.name for k, e in enumerate(self.epochs)})
            with step(f"writing {Path(path).name}", bands=len(rasters)), output_group():
                write_geotiff(path, rasters, descriptions, self.grid.transform, self.maps[0].crs,
                              overwrite=overwrite, tags=tags, meanings=meanings)
                write_style(style_path(path), when_style(self, len(rasters)), overwrite=overwrite)
        elif IMAGE in holds:
            from ..io.png import write_png
            from ..reporting import when_map_image

            with step(f"writing {Path(path).name}"):
                write_png(path, when_map_image(self), overwrite=overwrite)
        elif REPORT in holds:
            self.report().save(path, overwrite=overwrite)
        else:
            ext = Path(path).suffix.lower()
            raise LidarSigError(f"cannot write a change series as {ext or '(no extension)'!r}; use .tif, .gpkg, "
                                ".png or .html", path=path)

    def report(self) -> Report:
        """The HTML report: each interval's map and most changed cells, and the map of "when"."""
        from ..reporting import series_report

        return series_report(self)
