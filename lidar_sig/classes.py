"""Class tables: semantic codes -> class name and colour, for augmented signatures (SPEC 5)."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .errors import LidarSigError

OTHER_COLOR = (128, 128, 128)


@dataclass(frozen=True)
class ClassTable:
    """Semantic classes of a signature.

    Each class has a name, an RGB colour (0-255) and the label codes that map to it; codes
    outside the table go to a final class ``"other"``. Equal tables compare equal.
    """

    name: str
    names: tuple
    codes: tuple
    colors: tuple

    def __post_init__(self):
        if not (len(self.names) == len(self.codes) == len(self.colors)):
            raise LidarSigError("a class table needs one name, code list and colour per class")
        seen = [c for cs in self.codes for c in cs]
        if len(seen) != len(set(seen)):
            raise LidarSigError(f"class table {self.name!r} maps a code to two classes")

    @property
    def class_names(self):
        """All class names, ``"other"`` last."""
        return tuple(self.names) + ("other",)

    @property
    def class_colors(self):
        """(C, 3) float array of colours in [0, 1], ``other`` last."""
        return np.array(list(self.colors) + [OTHER_COLOR], dtype=np.float64) / 255.0

    def __len__(self):
        return len(self.names) + 1

    def index(self, labels):
        """Class index per point (0..C-1); codes outside the table -> the last, ``other``."""
        n = len(labels)
        if not self.codes or n == 0:
            return np.full(n, len(self.names), dtype=np.int64)
        labels = np.asarray(labels, dtype=np.int64)
        lut_size = max(max(cs) for cs in self.codes if cs) + 1
        lut = np.full(lut_size, len(self.names), dtype=np.int64)
        for k, cs in enumerate(self.codes):
            lut[list(cs)] = k
        inside = (labels >= 0) & (labels < lut_size)
        out = np.full(n, len(self.names), dtype=np.int64)
        out[inside] = lut[labels[inside]]
        return out


# ASPRS LAS 1.4 standard classes (R15), colours close to common viewer palettes.
ASPRS = ClassTable(
    "asprs",
    names=("created, never classified", "unclassified", "ground", "low vegetation",
           "medium vegetation", "high vegetation", "building", "low point (noise)",
           "reserved", "water", "rail", "road surface", "reserved", "wire guard",
           "wire conductor", "transmission tower", "wire connector", "bridge deck",
           "high noise"),
    codes=tuple((c,) for c in range(19)),
    colors=((200, 200, 200), (170, 170, 170), (166, 118, 60), (170, 220, 90),
            (80, 180, 60), (20, 110, 30), (220, 50, 40), (255, 0, 255),
            (100, 100, 100), (40, 110, 230), (140, 90, 160), (90, 90, 90),
            (100, 100, 100), (250, 200, 0), (250, 170, 0), (200, 120, 0),
            (250, 220, 120), (120, 200, 200), (255, 0, 180)),
)

# The four classes of the paper (tree, building, low vegetation, road), from ASPRS codes:
# tree = medium + high vegetation, road = ground + road surface.
PAPER = ClassTable(
    "paper",
    names=("tree", "building", "low vegetation", "road"),
    codes=((4, 5), (6,), (3,), (2, 11)),
    colors=((20, 140, 40), (220, 50, 40), (190, 230, 80), (120, 120, 120)),
)

# A cloud without labels has one class.
UNLABELED = ClassTable("unlabeled", names=(), codes=(), colors=())
BUILTIN = {"asprs": ASPRS, "paper": PAPER}


def class_table(name):
    """A built-in class table by name ('asprs' or 'paper'), or the table itself."""
    if isinstance(name, ClassTable):
        return name
    try:
        return BUILTIN[str(name).lower()]
    except KeyError:
        raise LidarSigError(f"unknown class table {name!r}; available: {', '.join(BUILTIN)}") from None
