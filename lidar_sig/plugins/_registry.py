"""Entry-point discovery of descriptors and strategies."""
from __future__ import annotations

from functools import lru_cache
from importlib import import_module
from importlib.metadata import entry_points

from ..base.errors import LidarSigError

GROUPS = {"descriptor": "lidar_sig.descriptors", "strategy": "lidar_sig.strategies"}

class _Plugin:
    def __init__(self, name, value, package):
        self.name, self.value, self.package = name, value, package

    def load(self):
        module, _, attr = self.value.partition(":")
        obj = import_module(module)
        for part in attr.split("."):
            obj = getattr(obj, part)
        return obj


@lru_cache(maxsize=None)
def _plugins(group):
    found = {}
    for ep in entry_points(group=group):
        package = ep.dist.name if ep.dist is not None else "?"
        found[ep.name] = _Plugin(ep.name, ep.value, package)
    if not any(p.package == "lidar_sig" for p in found.values()):
        # the built-ins are entry points of lidar_sig's own metadata (pyproject.toml): a source
        # tree that was never installed has none
        raise LidarSigError(f"lidar_sig's own plugins ({group}) are not registered: install it "
                            "(pip install -e . in its source tree, or pip install lidar-sig)")
    return found


def available(kind):
    """Registered plugins of ``kind`` ('descriptor' or 'strategy'): name -> (package, summary)."""
    out = {}
    for name, plugin in sorted(_plugins(GROUPS[kind]).items()):
        cls = plugin.load()
        out[name] = (plugin.package, getattr(cls, "summary", ""))
    return out


# The method each kind of plugin must have (see plugins/base.py).
_METHOD = {"descriptor": "saliency", "strategy": "combine"}


def _get(kind, name, **params):
    if not isinstance(name, str):
        if isinstance(name, type) or not callable(getattr(name, _METHOD[kind], None)):
            raise LidarSigError(f"{kind} must be a registered name ({', '.join(sorted(_plugins(GROUPS[kind])))}) "
                                f"or a {kind.capitalize()} instance, got {name!r}")
        return name  # an instance given directly
    plugins = _plugins(GROUPS[kind])
    key = name.lower()
    if key not in plugins:
        raise LidarSigError(f"unknown {kind} {name!r}; available: {', '.join(sorted(plugins))}")
    try:
        return plugins[key].load()(**params)
    except TypeError as exc:  # parameters the plugin does not take
        raise LidarSigError(f"{kind} {name!r} does not take these parameters ({exc})") from None


def get_descriptor(name, **params):
    """An instance of the descriptor registered as ``name`` (or ``name`` if already one)."""
    return _get("descriptor", name, **params)


def get_strategy(name, **params):
    """An instance of the strategy registered as ``name`` (or ``name`` if already one)."""
    return _get("strategy", name, **params)
