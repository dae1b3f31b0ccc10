"""Class tables: semantic codes -> class name and colour, for augmented signatures (docs/method.md, "Signatures")."""
from __future__ import annotations

import os
from dataclasses import dataclass, replace

import numpy as np

from ..base.errors import LidarSigError

OTHER_COLOR = (128, 128, 128)
#: Largest label code a class table may name (codes are stored as 32-bit integers).
MAX_CODE = 2**31 - 1


@dataclass(frozen=True)
class ClassTable:
    """Semantic classes of a signature.

    Each class has a name, an RGB colour (0-255) and the label codes that map to it; codes
    outside the table go to a final class ``"other"``. ``noise`` lists the codes that mean
    noise (ASPRS 7 low point and 18 high noise in the tables over ASPRS codes): a run leaves
    those points out unless ``keep_noise`` (:func:`lidar_sig.method.cloud.kept_points`). Equal tables
    compare equal.
    """

    name: str
    names: tuple
    codes: tuple
    colors: tuple
    noise: tuple = ()

    def __post_init__(self):
        if not (len(self.names) == len(self.codes) == len(self.colors)):
            raise LidarSigError("a class table needs one name, code list and colour per class")
        for c in self.noise:
            # 0 is "never classified" in ASPRS, and how a LAS file without classes reads
            if isinstance(c, bool) or not isinstance(c, (int, np.integer)) or not 1 <= c <= MAX_CODE:
                raise LidarSigError(f"class table {self.name!r}: noise codes must be whole numbers from 1 to "
                                    f"{MAX_CODE:,}, got {c!r}")
        for cs in self.codes:
            for c in cs:
                if isinstance(c, bool) or not isinstance(c, (int, np.integer)) or not 0 <= c <= MAX_CODE:
                    raise LidarSigError(f"class table {self.name!r}: codes must be whole numbers from 0 to "
                                        f"{MAX_CODE:,}, got {c!r}")
        seen = [int(c) for cs in self.codes for c in cs]
        if len(seen) != len(set(seen)):
            raise LidarSigError(f"class table {self.name!r} maps a code to two classes")
        names = [str(n) for n in self.names]
        twice = sorted({n for n in names if names.count(n) > 1 or n == "other"})
        if twice:  # a name stands for one class in counts, reports and archives
            raise LidarSigError(f"class table {self.name!r} names two classes {', '.join(map(repr, twice))} "
                                "('other' is the class of codes outside the table); give each class its own name")

    @property
    def class_names(self):
        """All class names, ``"other"`` last."""
        return tuple(self.names) + ("other",)

    @property
    def class_colors(self):
        """(C, 3) float array of colours in [0, 1], ``other`` last."""
        return np.array(list(self.colors) + [OTHER_COLOR], dtype=np.float64) / 255.0

    def __len__(self) -> int:
        return len(self.names) + 1

    def index(self, labels: np.ndarray) -> np.ndarray:
        """Class index per point (0..C-1); codes outside the table -> the last, ``other``.

        A sorted look-up of the table's codes, so memory does not grow with the largest code.
        """
        labels = np.asarray(labels)
        n = len(labels)
        other = len(self.names)
        if not self.codes or n == 0:
            return np.full(n, other, dtype=np.int64)
        codes = np.array([c for cs in self.codes for c in cs], dtype=np.int64)
        classes = np.array([k for k, cs in enumerate(self.codes) for _ in cs], dtype=np.int64)
        order = np.argsort(codes)
        codes, classes = codes[order], classes[order]
        labels = labels.astype(np.int64)
        pos = np.clip(np.searchsorted(codes, labels), 0, len(codes) - 1)
        return np.where(codes[pos] == labels, classes[pos], other)


#: ASPRS codes of noise: 7 low point (noise) and 18 high noise (defined from LAS 1.4 on; LAS 1.0-1.3
#: reserve 18, and it is read as high noise in any version).
ASPRS_NOISE = (7, 18)

# ASPRS LAS 1.4 standard classes (R15), colours close to common viewer palettes.
ASPRS = ClassTable(
    "asprs",
    names=("created, never classified", "unclassified", "ground", "low vegetation",
           "medium vegetation", "high vegetation", "building", "low point (noise)",
           "reserved (8)", "water", "rail", "road surface", "reserved (12)", "wire guard",
           "wire conductor", "transmission tower", "wire connector", "bridge deck",
           "high noise"),
    codes=tuple((c,) for c in range(19)),
    colors=((200, 200, 200), (170, 170, 170), (166, 118, 60), (170, 220, 90),
            (80, 180, 60), (20, 110, 30), (220, 50, 40), (255, 0, 255),
            (100, 100, 100), (40, 110, 230), (140, 90, 160), (90, 90, 90),
            (100, 100, 100), (250, 200, 0), (250, 170, 0), (200, 120, 0),
            (250, 220, 120), (120, 200, 200), (255, 0, 180)),
    noise=ASPRS_NOISE,
)

# The four classes of the paper (tree, building, low vegetation, road), from ASPRS codes:
# tree = medium + high vegetation, road = ground + road surface.
PAPER = ClassTable(
    "paper",
    names=("tree", "building", "low vegetation", "road"),
    codes=((4, 5), (6,), (3,), (2, 11)),
    colors=((20, 140, 40), (220, 50, 40), (190, 230, 80), (120, 120, 120)),
    noise=ASPRS_NOISE,
)

# ISPRS Vaihingen 3D semantic labeling benchmark (Niemeyer et al. 2014), labels 0-8.
ISPRS_VAIHINGEN = ClassTable(
    "isprs-vaihingen",
    names=("powerline", "low vegetation", "impervious surfaces", "car", "fence/hedge", "roof",
           "facade", "shrub", "tree"),
    codes=tuple((c,) for c in range(9)),
    colors=((250, 200, 0), (170, 220, 90), (150, 150, 150), (40, 110, 230), (140, 90, 60),
            (220, 50, 40), (240, 150, 120), (80, 180, 60), (20, 110, 30)),
)

# A cloud without labels has one class.
UNLABELED = ClassTable("unlabeled", names=(), codes=(), colors=())
BUILTIN = {"asprs": ASPRS, "paper": PAPER, "isprs-vaihingen": ISPRS_VAIHINGEN}


def recorded_table(name, names, codes, colors, noise=None):
    """A class table read back from a file (archive, catalogue): its noise codes as recorded,
    or, for a record made before they were kept (``noise`` None), those of the built-in table
    of the same name and classes (an ASPRS table without them would keep class 7 and 18 points
    that its file's signatures left out)."""
    table = ClassTable(str(name), names=tuple(names), codes=tuple(tuple(int(v) for v in c) for c in codes),
                       colors=tuple(tuple(int(v) for v in c) for c in colors),
                       noise=() if noise is None else tuple(int(v) for v in noise))
    if noise is None and table.name in BUILTIN and replace(BUILTIN[table.name], noise=()) == table:
        return BUILTIN[table.name]
    return table


def class_table(name: str | ClassTable) -> ClassTable:
    """A class table: built-in by name (asprs, paper, isprs-vaihingen), a TOML or JSON file of
    the user's (see :func:`load_class_table`), or the table itself."""
    if isinstance(name, ClassTable):
        return name
    text = str(name)
    if text.lower() in BUILTIN:
        return BUILTIN[text.lower()]
    if text.lower().endswith((".toml", ".json")):
        return load_class_table(text)
    raise LidarSigError(f"unknown class table {name!r}; use one of {', '.join(BUILTIN)} or a .toml/.json file")


def load_class_table(path: str | os.PathLike[str]) -> ClassTable:
    """A user class table from TOML or JSON: a ``name``, optionally ``noise`` (the codes of
    noise points, left out of a run unless ``keep_noise``; e.g. ``[7, 18]`` for ASPRS codes;
    none by default) and a list ``class`` of tables with ``name``, ``codes`` (one code or a
    list: several codes may map to one class) and ``color`` (RGB 0-255). Example (TOML)::

        name = "ign-vegetation"
        noise = [7, 18]
        [[class]]
        name = "vegetation"
        codes = [3, 4, 5]
        color = [20, 140, 40]
    """
    from pathlib import Path

    p = Path(path)
    if not p.is_file():
        raise LidarSigError("class table file not found; check the path", path=p)
    try:
        if p.suffix.lower() == ".toml":
            import tomllib

            data = tomllib.loads(p.read_text(encoding="utf-8"))
        else:
            import json

            data = json.loads(p.read_text(encoding="utf-8"))
    except (ValueError, UnicodeDecodeError) as exc:
        raise LidarSigError(f"cannot parse the class table ({str(exc).splitlines()[0][:120]})", path=p) from None
    entries = data.get("class") if isinstance(data, dict) else None
    if not isinstance(entries, list) or not entries:
        raise LidarSigError("a class table needs a list 'class' of {name, codes, color} entries", path=p)
    names, codes, colors = [], [], []
    for k, entry in enumerate(entries):
        try:
            c = entry["codes"]
            c = (c,) if not isinstance(c, list) else tuple(c)
            rgb = tuple(entry["color"])
            whole = all(isinstance(v, int) and not isinstance(v, bool) for v in c + rgb)
            if (not c or not whole or len(rgb) != 3 or not all(0 <= v <= 255 for v in rgb)
                    or not all(0 <= v <= MAX_CODE for v in c) or not isinstance(entry["name"], str)):
                raise ValueError
            names.append(entry["name"])
            codes.append(c)
            colors.append(rgb)
        except (KeyError, TypeError, ValueError):
            raise LidarSigError(f"class entry {k + 1} needs a name, codes that are whole numbers from 0 to "
                                f"{MAX_CODE:,} and an RGB color of three whole numbers 0-255", path=p) from None
    noise = data.get("noise", [])
    if not isinstance(noise, list) or not all(isinstance(v, int) and not isinstance(v, bool) for v in noise):
        raise LidarSigError("noise must be a list of class codes (whole numbers), e.g. noise = [7, 18]", path=p)
    try:
        return ClassTable(str(data.get("name", p.stem)), tuple(names), tuple(codes), tuple(colors), tuple(noise))
    except LidarSigError as exc:
        raise LidarSigError(str(exc), path=p) from None
