"""Descriptors and strategies found through entry points (:mod:`lidar_sig.base.extensions`)."""
from __future__ import annotations

from typing import Any, Literal, cast

from ..base.errors import LidarSigError
from ..base.extensions import Extension, registered
from ._kinds import Descriptor, Strategy

#: The two kinds of plugin of the method.
PluginKind = Literal["descriptor", "strategy"]
# The method each kind of plugin must have (see plugins/_kinds.py).
_METHOD = {"descriptor": "saliency", "strategy": "combine"}


def _class(extension: Extension) -> type:
    """The class an entry point of a descriptor or strategy names, checked to have its kind's method."""
    cls = extension.load()
    if not isinstance(cls, type) or not callable(getattr(cls, _METHOD[extension.kind], None)):
        raise extension.fault(f"is {cls!r}, not a class with a {_METHOD[extension.kind]}() method "
                              f"(derive it from lidar_sig.plugins.{extension.kind.capitalize()})")
    return cls


def available(kind: PluginKind) -> dict[str, tuple[str, str]]:
    """Registered plugins of ``kind`` ('descriptor' or 'strategy'): name -> (package, summary),
    lidar_sig's own first."""
    out = {}
    for name, extension in registered(kind).items():
        out[name] = (extension.distribution, str(getattr(_class(extension), "summary", "")))
    return out


def _get(kind: PluginKind, name: object, params: dict[str, Any]) -> object:
    if not isinstance(name, str):
        if isinstance(name, type) or not callable(getattr(name, _METHOD[kind], None)):
            raise LidarSigError(f"{kind} must be a registered name ({', '.join(sorted(registered(kind)))}) "
                                f"or a {kind.capitalize()} instance, got {name!r}")
        return name  # an instance given directly
    plugins = registered(kind)
    key = name.lower()
    if key not in plugins:
        raise LidarSigError(f"unknown {kind} {name!r}; available: {', '.join(sorted(plugins))}")
    cls = _class(plugins[key])
    try:
        return cls(**params)
    except TypeError as exc:  # parameters the plugin does not take
        raise LidarSigError(f"{kind} {name!r} does not take these parameters ({exc})") from None


def get_descriptor(name: str | Descriptor, **params: Any) -> Descriptor:
    """An instance of the descriptor registered as ``name`` (or ``name`` if already one)."""
    return cast(Descriptor, _get("descriptor", name, params))  # a class with saliency(), checked by _class


def get_strategy(name: str | Strategy, **params: Any) -> Strategy:
    """An instance of the strategy registered as ``name`` (or ``name`` if already one)."""
    return cast(Strategy, _get("strategy", name, params))  # a class with combine(), checked by _class
