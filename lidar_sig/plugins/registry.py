"""Entry-point discovery of descriptors and strategies."""
from __future__ import annotations

from functools import lru_cache
from importlib import import_module
from importlib.metadata import entry_points

from ..errors import LidarSigError

GROUPS = {"descriptor": "lidar_sig.descriptors", "strategy": "lidar_sig.strategies"}

# The built-ins as declared in pyproject.toml; used only when lidar_sig runs from a source tree
# that was never installed (no distribution metadata), so that the entry points are missing.
_BUILTIN = {
    "lidar_sig.descriptors": {
        "c3dcm": "lidar_sig.plugins.descriptors.c3dcm:C3DCM",
        "t3dvt": "lidar_sig.plugins.descriptors.t3dvt:T3DVT",
        "t3dvt-get": "lidar_sig.plugins.descriptors.t3dvt_get:T3DVTGET",
    },
    "lidar_sig.strategies": {
        "multiscale": "lidar_sig.plugins.strategies.multiscale:Multiscale",
        "optimal": "lidar_sig.plugins.strategies.optimal:OptimalScale",
    },
}


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
    for name, value in _BUILTIN[group].items():
        found.setdefault(name, _Plugin(name, value, "lidar_sig"))
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
