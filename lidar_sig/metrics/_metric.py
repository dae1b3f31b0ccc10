"""What a metric is (:class:`Metric`): its key and name, its range, the value of identical
signatures and its direction, whether it needs labels, how it is computed from two
:class:`Operand`, and where a value stands among the values the project measured."""
from __future__ import annotations

import math
import numbers
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..base.errors import LidarSigError, a_kind
from ..base.extensions import Extension

#: The cases a value is placed against (docs/comparison.md, the ordering benchmark), nearest first.
REFERENCE_CASES = {
    "rotated": "the same land rotated",
    "resampled": "the same land resampled to 80% or 60% of its points",
    "adjacent": "the adjacent tile of the same survey",
    "another_place": "a tile of another city",
}
#: Values within this of a metric's ``same`` value read as "the same land" (rotated copies give
#: the same value to four decimals).
SAME_WITHIN = 5e-5


class Operand(Protocol):
    """What a metric reads of one signature (:attr:`Metric.of`): a signature's
    (:class:`lidar_sig.metrics.SignatureOperand`) or a catalogue tile's, from its stored vectors."""

    @property
    def sg(self) -> NDArray[np.float64]:
        """Sg, the geometric signature image (frame x frame, values in [0, 1])."""

    @property
    def color(self) -> NDArray[np.float64]:
        """The colour histogram of Sas (``color_bins`` per RGB channel, R major), summing to 1."""

    @property
    def color_bins(self) -> int:
        """Bins per RGB channel of :attr:`color`."""

    @property
    def mask(self) -> NDArray[np.bool_] | None:
        """The frame's triangle, where the images hold the signature."""

    @property
    def egeom(self) -> NDArray[np.int64]:
        """Counts of the Egeom histogram over [0, ln 3] nats."""

    @property
    def fv(self) -> NDArray[np.float64]:
        """The Fisher vector of the saliency positions (:func:`lidar_sig.metrics.signature_fisher_vector`)."""

    @property
    def totals(self) -> NDArray[np.int64]:
        """Points per class of the class table (all zero but the first for an unlabelled cloud)."""


@dataclass(frozen=True, repr=False)
class Metric:
    """A metric of :func:`~lidar_sig.metrics.compare`: its key, the paper's name, its range, the
    value of two identical signatures (``same``), whether a larger value means more different, a
    short definition and what it reacts to, in a user's words; ``references``: the lowest and
    highest value the project measured between a tile and the same land resampled, the adjacent
    tile and another city ({case: (low, high)}, the 7 references of docs/comparison.md's ordering
    benchmark with the defaults; a rotated copy gives ``same``; None for a metric without them);
    how it is computed (``of``, from two :class:`Operand`), whether it ``needs_labels`` (None when
    a cloud has none), and its form over ``rows`` of vectors when it comes from each signature's
    vectors alone (colour histogram, Egeom histogram, Fisher vector, class totals: a catalogue
    screens every pair with it) rather than from images or a transport problem per pair.

    A package adds one through the entry-point group ``lidar_sig.metrics`` (docs/extending.md);
    ``extension`` then says which (:mod:`lidar_sig.base.extensions`), for its errors."""

    key: str
    name: str
    range: str
    same: float
    larger_differs: bool
    short: str
    reacts: str
    references: dict[str, tuple[float, float]] | None = None
    of: Callable[[Operand, Operand], float] | None = None
    needs_labels: bool = False
    rows: Callable[[Any, Any], NDArray[np.float64]] | None = None
    extension: Extension | None = None

    @property
    def built_in(self) -> bool:
        """Whether the metric is lidar_sig's own (or made here, not registered by a package)."""
        return self.extension is None or self.extension.built_in

    @property
    def from_vectors(self) -> bool:
        """Whether the metric has a row-wise form (:attr:`rows`: every row of one set of
        signature vectors against every row of another, a (Q, N) array), so that a catalogue
        screens all its pairs with a few array operations."""
        return self.rows is not None

    @property
    def distance_name(self) -> str:
        """The name of :meth:`distance`: "1 - s_SSIM" for s_SSIM, the metric's name for the others."""
        return self.name if self.larger_differs else f"{self.same:g} - {self.name}"

    def distance(self, values: ArrayLike) -> NDArray[np.float64]:
        """``values`` of this metric as distances from identical clouds, larger meaning more
        different (0 = the same): 1 - s_SSIM for s_SSIM, the values themselves for the others."""
        values = np.asarray(values, dtype=np.float64)
        return values - self.same if self.larger_differs else self.same - values

    def value(self, a: Operand, b: Operand) -> float:
        """The metric between two operands (:attr:`of`). Another package's metric that fails, or
        gives something that is not a number, is a LidarSigError naming it and its package."""
        if self.of is None:
            raise LidarSigError(f"metric {self.key!r} has no function (of) to compute it with")
        out = self._run(self.of, a, b)
        if isinstance(out, (bool, np.bool_)) or not isinstance(out, (numbers.Real, np.number)):
            raise self._fault(f"returned {a_kind(out)}, not a number")
        if not self.built_in and not math.isfinite(float(out)):  # NaN is not JSON, and ranks nothing
            raise self._fault(f"returned {float(out)}, not a finite number")
        return float(out)

    def between_rows(self, a: Any, b: Any) -> NDArray[np.float64]:
        """The metric between every row of ``a`` and every row of ``b`` (:attr:`rows`), (Q, N)."""
        if self.rows is None:
            raise LidarSigError(f"metric {self.key!r} has no row-wise form")
        out = self._run(self.rows, a, b)
        if not isinstance(out, np.ndarray) or out.dtype.kind not in "iuf":
            raise self._fault(f"returned {a_kind(out)} from its rows, not an array of numbers")
        out = out.astype(np.float64, copy=False)
        if not self.built_in and not np.isfinite(out).all():
            raise self._fault(f"returned {np.count_nonzero(~np.isfinite(out)):,} values that are not finite (NaN or "
                              "inf) from its rows")
        return out

    def _run(self, compute: Callable[[Any, Any], Any], a: Any, b: Any) -> Any:
        if self.extension is None or self.built_in:
            return compute(a, b)  # lidar_sig's own: a failure is a bug, with its traceback
        return self.extension.run("failed", compute, a, b)  # another package's code: named, in one line

    def _fault(self, what: str, exc: BaseException | None = None) -> LidarSigError:
        if self.extension is None:
            return LidarSigError(f"metric {self.key!r} {what}" + (f" ({type(exc).__name__}: {exc})" if exc else ""))
        return self.extension.fault(what, exc)

    def __repr__(self) -> str:
        return f"<Metric {self.name} ({self.key}): {self.range}, {self.same:g} = same>"

    def _oriented(self, value: float) -> float:
        return float(value) if self.larger_differs else self.same - float(value)

    def place(self, value: float) -> tuple[str, str]:
        """The reference case ``value`` is most like (a key of :data:`REFERENCE_CASES`) and a
        phrase saying so. The cases split at the geometric mean of the highest value of one
        case and the lowest of the next (their ranges may overlap); a value within
        :data:`SAME_WITHIN` of ``same`` is "rotated", one above every other city's "beyond"; a
        metric without references places nothing ("unplaced")."""
        v = self._oriented(value)
        if abs(v) < SAME_WITHIN:
            return "rotated", f"as the same land, rotated ({self.same:g})"
        if not self.references:
            return "unplaced", "no reference values to place it among"
        cases = list(self.references)
        ranges = [sorted(self._oriented(x) for x in self.references[c]) for c in cases]
        for k, case in enumerate(cases[:-1]):
            if v < (ranges[k][1] * ranges[k + 1][0]) ** 0.5:
                return case, f"like {REFERENCE_CASES[case]} ({self.shown_range(case)})"
        if v > ranges[-1][1]:
            return "beyond", f"beyond {REFERENCE_CASES[cases[-1]]} ({self.shown_range(cases[-1])})"
        return cases[-1], f"like {REFERENCE_CASES[cases[-1]]} ({self.shown_range(cases[-1])})"

    def shown_range(self, case: str) -> str:
        """The range of a reference case as text, e.g. ``0.2187-0.5872``."""
        low, high = (self.references or {})[case]
        return f"{low:.4f}-{high:.4f}"

    def scale(self, value: float) -> dict[str, Any]:
        """``value`` placed on the project's reference values, as plain values for JSON."""
        case, says = self.place(value)
        return {"name": self.name, "like": case, "says": says, "rotated": self.same,
                **{c: list(r) for c, r in (self.references or {}).items()}}
