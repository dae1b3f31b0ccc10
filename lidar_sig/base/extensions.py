"""The extension points: what lidar_sig and the packages installed beside it add through entry
points (docs/extending.md). Five kinds, each an entry-point group: descriptors, scale strategies,
metrics, point-cloud formats and commands. A package declares its extensions in its own metadata
(``[project.entry-points."lidar_sig.metrics"]`` in its pyproject.toml), and lidar_sig declares
its built-ins the same way, so that both are found alike.

Listing the extensions reads the installed packages' metadata only and imports nothing;
an extension's module is imported when it is first used. An extension that cannot be loaded or
does not do what its kind must is a :class:`~lidar_sig.base.errors.LidarSigError` naming it and
the package it came from (:meth:`Extension.fault`): the command line's one line and exit status 2.
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from functools import lru_cache
from importlib import import_module
from importlib.metadata import entry_points
from typing import Any

from .errors import LidarSigError, printable

#: The entry-point group of each kind of extension, in the order ``lidar-sig plugins`` lists them.
GROUPS = {"descriptor": "lidar_sig.descriptors", "strategy": "lidar_sig.strategies",
          "metric": "lidar_sig.metrics", "format": "lidar_sig.formats", "command": "lidar_sig.commands"}
#: The kinds in the plural, as listings title them.
TITLES = {"descriptor": "descriptors", "strategy": "strategies", "metric": "metrics", "format": "formats",
          "command": "commands"}
#: The distribution (installed package) of lidar_sig itself: its extensions are the built-ins.
OWN = "lidar_sig"


@dataclass(frozen=True)
class Extension:
    """One registered extension: its ``kind`` (a key of :data:`GROUPS`), its ``name`` (the entry
    point's), where it is (``value``, ``"module:attribute"``) and the ``distribution`` (installed
    package) that declares it."""

    kind: str
    name: str
    value: str
    distribution: str

    @property
    def built_in(self) -> bool:
        """Whether lidar_sig declares it itself."""
        return self.distribution == OWN

    @property
    def who(self) -> str:
        """The extension and its package, as messages name it: ``metric 'area' of lidar-sig-example``."""
        return f"{self.kind} {self.name!r} of {self.distribution}"

    def load(self) -> Any:
        """The object the entry point names, its module imported now; a LidarSigError naming the
        extension when another package's cannot be loaded (a built-in that cannot is a fault of
        this installation, and keeps its traceback)."""
        return self.run("cannot be loaded", self._resolve)

    def run(self, failed: str, function: Callable[..., Any], *args: Any, **kwargs: Any) -> Any:
        """``function(*args, **kwargs)``, code of this extension: the one error path of everything
        a plugin does. Another package's failure of any kind, ``sys.exit`` included, is a
        LidarSigError naming it (``failed``: "failed", "cannot be loaded", ...) and its package;
        its own LidarSigError and an interrupt (Ctrl-C) pass as they are. A built-in's failure is
        a bug of lidar_sig and keeps its traceback."""
        if self.built_in:
            return function(*args, **kwargs)
        try:
            return function(*args, **kwargs)
        except (LidarSigError, KeyboardInterrupt):
            raise
        except BaseException as exc:  # noqa: BLE001 - the package's code: SystemExit too is its failure
            raise self.fault(failed, exc) from None

    def _resolve(self) -> Any:
        module, _, attribute = self.value.partition(":")
        found: Any = import_module(module.strip())
        for part in filter(None, attribute.strip().split(".")):
            found = getattr(found, part)
        return found

    def fault(self, what: str, exc: BaseException | None = None) -> LidarSigError:
        """The error of this extension, which ``what`` ("cannot be loaded", "returned a list, not
        a number"), with the exception that said so: one line naming the extension, its package
        and the fix."""
        cause = f" ({type(exc).__name__}: {printable(str(exc))[:300]})" if exc is not None else ""
        fix = ("reinstall lidar_sig" if self.built_in
               else f"fix it in {self.distribution}, or uninstall that package (pip uninstall {self.distribution})")
        return LidarSigError(f"{self.who} {what}{cause}; {fix}")


@lru_cache(maxsize=None)
def registered(kind: str) -> dict[str, Extension]:
    """The extensions of ``kind`` (a key of :data:`GROUPS`) by name: lidar_sig's own first, in
    the order its metadata declares them (the order of every table of metrics), then those of
    other packages by package and name. Nothing is imported. A LidarSigError when lidar_sig's own
    are missing (a source tree never installed) or two packages declare one name."""
    found, clashes = registered_apart(kind)
    if clashes:
        raise clashes[0]
    return found


@lru_cache(maxsize=None)
def registered_apart(kind: str) -> tuple[dict[str, Extension], list[LidarSigError]]:
    """The extensions of ``kind`` by name as :func:`registered` gives them, each name kept by its
    first declaration (lidar_sig's own before another package's), and the errors of the others
    that declare a name again, set apart (the command group runs the other commands and notes
    them). A LidarSigError when lidar_sig's own are missing."""
    group = GROUPS[kind]
    own: list[Extension] = []
    others: list[Extension] = []
    for point in entry_points(group=group):
        distribution = point.dist.name if point.dist is not None else "an unknown package"
        extension = Extension(kind, point.name, point.value, distribution)
        (own if extension.built_in else others).append(extension)
    if not own:
        # the built-ins are entry points of lidar_sig's own metadata (pyproject.toml): a source
        # tree that was never installed has none
        raise LidarSigError(f"lidar_sig's own {TITLES[kind]} ({group}) are not registered: install it "
                            "(pip install -e . in its source tree, or pip install lidar-sig)")
    found: dict[str, Extension] = {}
    clashes: list[LidarSigError] = []
    for extension in own + sorted(others, key=lambda e: (e.distribution, e.name)):
        if extension.name in found:
            first = found[extension.name]
            clashes.append(extension.fault(f"has the name of the {kind} of {first.distribution}: each name is one "
                                           f"{kind}'s; rename one of them"))
        else:
            found[extension.name] = extension
    return found, clashes


def forget() -> None:
    """Forget what :func:`registered` found: the next call reads the installed packages again
    (after installing one in the running process, or in a test)."""
    registered.cache_clear()
    registered_apart.cache_clear()
