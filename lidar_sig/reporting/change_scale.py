"""The one colour scale of change (docs/changes.md, "Colours"): every face of a change map (the
GeoTIFF's QGIS style, the cells' style, the ``--png`` map, the report's maps, the notebook card's
picture, a series' maps) colours a cell through :data:`CHANGE_SCALE`.

A compared cell is coloured by its ``lod_ratio``, how far it lies from its level of detection
(1 at the level; above 1 exactly where significant), in fixed classes: the same on every map,
never scaled to one map's largest value, so that two maps compare by eye and a map of an epoch
against itself has no warm colour. The cells are ranked by the same value (significant first),
so the most changed cell is drawn in the strongest class. A cell not compared takes its
coverage state's colour, none of them warm and none white.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class ChangeScale:
    """Classes of the quantity ``quantity`` (a field of a change map's table): ``classes``
    ((upper bound, RGB, legend label), ascending; a value takes the first class whose bound it
    does not exceed; the last bound may be inf); ``states`` {coverage state: (RGB, legend label)}
    of the cells not compared; the outline of a significant cell (``outline``, dark) with a light
    ``halo`` around it, so that it shows on every class."""

    quantity: str
    classes: tuple
    states: dict
    outline: tuple = (20, 20, 20)
    halo: tuple = (255, 255, 255)
    #: The class bound that is the significance test: classes above it are the warm ones.
    level: float = 1.0

    @property
    def colours(self) -> np.ndarray:
        """(classes, 3) uint8: each class's colour, weakest first."""
        return np.array([rgb for _, rgb, _ in self.classes], np.uint8)

    @property
    def bounds(self) -> np.ndarray:
        return np.array([b for b, _, _ in self.classes], np.float64)

    @property
    def warm(self) -> np.ndarray:
        """(classes,) bool: the classes above the level of detection (changed significantly)."""
        return self.bounds > self.level

    def class_of(self, values) -> np.ndarray:
        """(N,) int: the class of each value (0 weakest); -1 where the value is NaN."""
        values = np.asarray(values, np.float64)
        k = np.searchsorted(self.bounds, np.nan_to_num(values, nan=0.0), side="left")
        k = np.minimum(k, len(self.classes) - 1)
        return np.where(np.isnan(values), -1, k)

    def cell_colours(self, values, states) -> np.ndarray:
        """(N, 3) uint8: each cell's colour: its class's where ``values`` is defined (a compared
        cell), else the colour of its coverage state (``states``, names as
        :data:`STATE_NAMES`: "appeared", "vanished", "too few points", "not covered")."""
        k = self.class_of(values)
        out = self.colours[np.maximum(k, 0)].copy()
        states = np.asarray(states, dtype=object)
        for name, (rgb, _) in self.states.items():
            out[(k < 0) & (states == name)] = rgb
        return out

    def qgis_classes(self) -> list:
        """[(upper bound, RGB, label)]: the classes as a QGIS style's discrete ramp."""
        return list(self.classes)


#: The classes of lod_ratio: greys up to 1 (not significant: the weaker, the lighter), ColorBrewer
#: YlOrRd above it (the significance test is the break at 1).
LEVEL_CLASSES = ((0.25, (240, 240, 240), "under 0.25 x its level of detection"),
                 (0.5, (212, 212, 212), "0.25 to 0.5 x"),
                 (1.0, (166, 166, 166), "0.5 to 1 x: not significant"),
                 (2.0, (254, 217, 118), "1 to 2 x: changed significantly"),
                 (5.0, (253, 141, 60), "2 to 5 x"),
                 (20.0, (240, 59, 32), "5 to 20 x"),
                 (100.0, (189, 0, 38), "20 to 100 x"),
                 (float("inf"), (103, 0, 13), "over 100 x"))

#: The cells not compared, each state its own colour: cool or neutral, none white, none warm.
STATES = {"appeared": ((33, 113, 181), "appeared: only the later epoch has points"),
          "vanished": ((136, 65, 157), "vanished: only the earlier epoch has points"),
          "too few points": ((140, 150, 170), "too few points to compare"),
          "not covered": ((205, 225, 215), "not covered: neither epoch has points")}
#: The states' names by the table's coverage code (lidar_sig.change_map._cells.COVERAGE).
STATE_NAMES = ("not covered", "compared", "appeared", "vanished", "too few points")

#: The scale every face of a change map colours its cells with.
CHANGE_SCALE = ChangeScale("lod_ratio", LEVEL_CLASSES, STATES)


def table_colours(table, scale=CHANGE_SCALE, drawn=None) -> np.ndarray:
    """(cells, 3) uint8: the colour of each cell of a change map's ``table`` through ``scale``:
    a compared cell by its class of ``scale.quantity``, the others by their coverage state; a
    cell not ``drawn`` ((cells,) bool: the slivers of a survey's edge, which the cells layer
    leaves out) as not covered, as QGIS shows it."""
    values = np.where(table["valid"], np.asarray(table[scale.quantity], np.float64), np.nan)
    states = np.array(STATE_NAMES, dtype=object)[np.asarray(table["coverage"], np.int64)]
    if drawn is not None:
        states[~np.asarray(drawn, bool)] = "not covered"
    return scale.cell_colours(values, states)


#: The states' colours in words, for legends in text.
STATE_WORDS = {"appeared": "blue", "vanished": "purple", "too few points": "slate", "not covered": "pale green"}


def legend_text(scale=CHANGE_SCALE) -> str:
    """The scale's legend in one line of words (a notebook card's note)."""
    states = ", ".join(f"{STATE_WORDS[name]}: {name}" for name in scale.states)
    return (f"colour: how far each cell lies from its level of detection ({scale.quantity}), greys up to 1 x (not "
            f"significant), yellow to dark red above 1 x (changed significantly: outlined), the same classes on "
            f"every map; {states}; numbers: rank, most changed first")
