"""lidar_sig: augmented semantic signatures of airborne LiDAR point clouds, for comparison.

Sreevalsan-Nair & Mohapatra, "Augmented Semantic Signatures of Airborne LiDAR Point Clouds
for Comparison". A cloud's per-point saliency map (Cl, Cs, Cp), placed in barycentric
coordinates of a fixed triangle, makes an image: the geometric signature Sg, or coloured by
semantic class, the augmented semantic signature Sas; metrics between signatures compare clouds.

The public names, listed in ``__init__.pyi`` (which editors and type checkers read), are loaded
on first use (PEP 562; the stub is read with ``ast``), so that ``import lidar_sig`` and the start of
the command line are quick and a Ctrl-C at that moment is handled like any other.
"""
# When this package is the command line starting, Ctrl-C and SIGTERM wait from here until it
# handles them (lidar_sig/base/start.py); a program that imports lidar_sig is left alone. A
# Ctrl-C that came while Python read this file is raised at the first call of Python code here:
# that first call installs a handler that records it (said later, or given back to the handler
# it replaced); then both signals are held, and lidar_sig.base.start decides (a Ctrl-C inside
# `from .base import start` was a traceback). Only the C module, loaded with the interpreter.
import _signal


def _received(signum, frame):
    _RECEIVED.append(signum)


_RECEIVED: list = []
try:
    _HANDLER_BEFORE = _signal.signal(_signal.SIGINT, _received)
except ValueError:  # imported in another thread than the main one, which alone takes handlers
    _HANDLER_BEFORE = _received
_HELD_BEFORE = (_signal.pthread_sigmask(_signal.SIG_BLOCK, {_signal.SIGINT, _signal.SIGTERM})
                if hasattr(_signal, "pthread_sigmask") else None)

from .base import start  # noqa: E402

start.hold(_HELD_BEFORE, handler=(_received, _HANDLER_BEFORE), received=_RECEIVED)

__version__ = "0.1.0"

import ast  # noqa: E402
import importlib  # noqa: E402
import warnings  # noqa: E402
from pathlib import Path  # noqa: E402

# numba probes the TBB threading layer first and warns when an older TBB (such as the one
# Open3D ships) is on the path; it then uses OpenMP or its own work queue, which is all we need.
warnings.filterwarnings("ignore", message=".*The TBB threading layer requires TBB")



def _public_names():
    """{public name: (module, attribute)} from the stub ``__init__.pyi``: ``from .m import x``
    gives ``x`` from module ``lidar_sig.m`` (an attribute, or its submodule ``x``); ``from . import
    m as y`` gives the subpackage ``lidar_sig.m`` as ``y``."""
    where = {}
    for node in ast.parse(Path(__file__).with_suffix(".pyi").read_text(encoding="utf-8")).body:
        if isinstance(node, ast.ImportFrom):
            module = __name__ + ("." + node.module if node.module else "")
            for alias in node.names:
                where[alias.asname or alias.name] = (module, alias.name)
    return where


_WHERE = _public_names()
__all__ = sorted(_WHERE)


def __getattr__(name):
    if name not in _WHERE:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    module, attribute = _WHERE[name]
    if module == __name__:  # a subpackage: ``from . import io``
        value = importlib.import_module(f"{module}.{attribute}")
    else:
        try:
            value = getattr(importlib.import_module(module), attribute)
        except AttributeError:  # a submodule not yet imported: ``from .base import errors``
            value = importlib.import_module(f"{module}.{attribute}")
    globals()[name] = value
    return value


def __dir__():
    return sorted(set(globals()) | set(_WHERE))
