"""Scale-out: a set of points cut into processing tiles with halos, run on local processes or a
Dask cluster; per-tile results equal the single-block run's (see :mod:`lidar_sig.tiling._core`).

What a run made is read back by :class:`SetRun`; what a run of one file keeps in its work folder
until asked for, by :class:`KeptTiles` (:class:`lidar_sig.pipeline.result.TiledResult` is its
Result). Both are loaded on first use (PEP 562), as the package's other names.
"""
from typing import TYPE_CHECKING

import lazy_loader

if TYPE_CHECKING:
    from ._set_run import KeptTiles as KeptTiles
    from ._set_run import SetRun as SetRun

# name -> the module of this package that defines it, loaded on first use
_EXPORTS = {"KeptTiles": "_set_run", "SetRun": "_set_run"}

__getattr__, __dir__, __all__ = lazy_loader.attach(
    __name__, submod_attrs={m: [n for n, where in _EXPORTS.items() if where == m] for m in set(_EXPORTS.values())})
