"""The metrics installed: lidar_sig's own and other packages', found through the entry-point group
``lidar_sig.metrics`` (:mod:`lidar_sig.base.extensions`) when first asked for, each checked to be
a :class:`~lidar_sig.metrics.Metric` keyed by its entry point's name."""
from __future__ import annotations

import dataclasses
from functools import lru_cache
from typing import Any

from ..base.errors import LidarSigError
from ..base.extensions import Extension, registered
from ._metric import Metric


def _loaded(extension: Extension) -> Metric:
    metric = extension.load()
    if not isinstance(metric, Metric):
        raise extension.fault(f"is {metric!r}, not a lidar_sig.metrics.Metric")
    if metric.key != extension.name:
        raise extension.fault(f"is keyed {metric.key!r}: a metric's key is its entry point's name")
    if not callable(metric.of):
        raise extension.fault("has no function (of) to compute it with")
    return dataclasses.replace(metric, extension=extension)


@lru_cache(maxsize=None)
def tables() -> dict[str, Any]:
    """The tables of the installed metrics, by the names :mod:`lidar_sig.metrics` gives them:
    ``METRICS`` (every :class:`Metric`, lidar_sig's own first, in the paper's order), ``METRIC_KEYS``,
    ``SEMANTIC_KEYS`` (those that need labels), ``METRIC_NAMES`` (key -> the paper's name) and
    ``METRIC`` (key -> Metric)."""
    from ._builtin import PAPER_ORDER

    first = [m.key for m in PAPER_ORDER]
    metrics = tuple(sorted((_loaded(extension) for extension in registered("metric").values()),
                           key=lambda m: first.index(m.key) if m.extension and m.extension.built_in else len(first)))
    names = [m.name for m in metrics]
    twice = sorted({n for n in names if names.count(n) > 1})
    if twice:
        raise LidarSigError(f"the metric name {twice[0]!r} is given twice "
                            f"({', '.join(m.extension.who for m in metrics if m.name == twice[0] and m.extension)}); "
                            "each metric's name is its own: rename one")
    return {"METRICS": metrics, "METRIC_KEYS": tuple(m.key for m in metrics),
            "SEMANTIC_KEYS": tuple(m.key for m in metrics if m.needs_labels),
            "METRIC_NAMES": {m.key: m.name for m in metrics}, "METRIC": {m.key: m for m in metrics}}
