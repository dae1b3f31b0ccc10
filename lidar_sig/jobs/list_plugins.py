"""What is installed to extend lidar_sig (``lidar-sig plugins``; docs/extending.md): every
descriptor, scale strategy, metric, point-cloud format and command, lidar_sig's own and other
packages', each with the package it came from and what it declares."""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from ..base.errors import LidarSigError, LidarSigWarning
from ..base.extensions import TITLES, registered_apart
from ._common import JobRun


@dataclass(repr=False)
class Plugins(JobRun):
    """What :func:`plugins` found: ``found``, for each kind in the plural ("descriptors",
    "strategies", "metrics", "formats", "commands"), a dict by name of what each declares, its
    ``package`` first."""

    found: dict[str, dict[str, dict[str, Any]]] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        return dict(self.found)

    def __repr__(self) -> str:
        counts = ", ".join(f"{len(names)} {title}" for title, names in self.found.items())
        return f"<Plugins {counts}>"


def plugins() -> Plugins:
    """Every installed extension by kind, in the order of the tables that use them (lidar_sig's
    own first): a descriptor's or strategy's summary; a metric's name, definition, range, value of
    identical signatures, direction and need of labels; a format's name, extensions, what it holds
    and whether it reads and writes point clouds; a command's short help. Loading one that fails is
    a LidarSigError naming it and its package."""
    from ..io.formats import formats
    from ..metrics import METRICS
    from ..plugins import available

    found: dict[str, dict[str, dict[str, Any]]] = {}
    for kind in ("descriptor", "strategy"):
        found[TITLES[kind]] = {name: {"package": package, "summary": summary}
                               for name, (package, summary) in available(kind).items()}
    found[TITLES["metric"]] = {m.key: {"package": _package(m.extension), "name": m.name, "summary": m.short,
                                       "range": m.range, "same": m.same, "larger_differs": m.larger_differs,
                                       "needs_labels": m.needs_labels} for m in METRICS}
    found[TITLES["format"]] = {f.extension.name if f.extension else f.name: {
        "package": _package(f.extension), "summary": f.name, "extensions": list(f.extensions), "holds": list(f.holds),
        "reads": f.reader is not None, "writes": f.writer is not None} for f in formats()}
    found[TITLES["command"]] = _commands()
    return Plugins(found=found, lines=_lines(found))


def _commands() -> dict[str, dict[str, Any]]:
    """The commands with their package and short help; one that cannot be loaded, or that is named
    like another, is left out with a note naming its package (the others still run, as
    ``lidar-sig --help`` lists them)."""
    import warnings

    found, clashes = registered_apart("command")
    out = {}
    for clash in clashes:
        warnings.warn(str(clash), LidarSigWarning, stacklevel=3)
    for name, extension in found.items():
        try:
            command = extension.load()
        except LidarSigError as exc:
            warnings.warn(f"{exc} (left out of this list)", LidarSigWarning, stacklevel=3)
            continue
        out[name] = {"package": extension.distribution, "summary": _short_help(command)}
    return out


def _package(extension: Any) -> str:
    return extension.distribution if extension is not None else "lidar_sig"


def _short_help(command: Any) -> str:
    """A click command's short help (the first sentence of its docstring), as the help lists it."""
    short = getattr(command, "get_short_help_str", None)
    return str(short(limit=80)) if callable(short) else ""


def _lines(found: dict[str, dict[str, dict[str, Any]]]) -> list[str]:
    """The listing for people: a title per kind, a line per extension (name, package, what it is)."""
    lines = []
    width = max([12, *(len(name) for names in found.values() for name in names)])
    packages = max([14, *(len(facts["package"]) + 1 for names in found.values() for facts in names.values())])
    for title, names in found.items():
        lines.append(f"{title}:")
        for name, facts in names.items():
            what = facts["summary"]
            if title == TITLES["metric"]:
                what = f"{facts['name']}: {what} ({facts['range']}, {facts['same']:g} = same)"
            elif title == TITLES["format"]:
                ways = " and ".join(w for w, can in (("read", facts["reads"]), ("written", facts["writes"])) if can)
                what += f" {' '.join(facts['extensions'])}: {', '.join(facts['holds'])}" + (f", {ways}" if ways else "")
            lines.append(f"  {name:<{width}} {facts['package']:<{packages}} {what}")
    return lines
