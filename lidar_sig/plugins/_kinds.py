"""Base classes of the two plugin kinds of the method: what a descriptor and a scale strategy
implement (docs/extending.md)."""
from __future__ import annotations

from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..base.errors import LidarSigError
from ..method.saliency_map import saliency_from_eigenvalues

if TYPE_CHECKING:
    from ..method.scales import Scales
    from ..numerics.neighbors import NeighborhoodBatch, ScaleKind

#: Compiled (numba) functions a plugin calls, as ``(module, (function, ...))`` pairs.
Kernels = tuple[tuple[str, tuple[str, ...]], ...]

#: Negative eigenvalues down to this share of a tensor's largest eigenvalue (in magnitude) are
#: round-off, set to 0 (docs/method.md, "Saliency map"); a more negative one is an error of the descriptor.
ROUND_OFF = 1e-6


class Descriptor:
    """Local geometric descriptor: a neighbourhood batch -> per-scale saliency (docs/method.md,
    "C3DCM", and docs/descriptors.md).

    Subclasses set ``name`` and ``summary`` and give either ``eigenvalues(batch)``, returning
    the (B, S, 3) eigenvalues (in any order, >= 0 up to round-off, NaN where undefined) of the
    tensor at each scale, or override ``saliency(batch)`` directly. ``kernels`` lists the
    compiled (numba) functions it calls, as ``(module, (function, ...))`` pairs: a run loads
    them before its first step, the first run after installing says that they compile, and
    later runs warm them up in the background (:mod:`lidar_sig.base.compile`); a descriptor that
    lists none gets no warm-up (whatever it compiles, it compiles in the run's own thread).
    ``tileable`` says
    whether a run may cut the cloud into tiles with halos (docs/scale-out.md).
    """

    name: ClassVar[str] = ""
    summary: ClassVar[str] = ""
    kernels: ClassVar[Kernels] = ()

    def __repr__(self) -> str:
        params = ", ".join(f"{k}={v!r}" for k, v in self.params().items())
        return f"<descriptor {self.name}" + (f" ({params})" if params else "") + ">"

    @property
    def tileable(self) -> bool:
        """True when a tile's block gives its points the whole cloud's saliency: every
        descriptor whose tensors come from the neighbourhoods alone. One that needs a pass over
        the whole cloud first (it overrides :meth:`prepare`) runs as one block; a subclass may
        say otherwise by setting ``tileable`` itself."""
        return type(self).prepare is Descriptor.prepare

    def eigenvalues(self, batch: NeighborhoodBatch) -> NDArray[np.float64]:
        """(B, S, 3) eigenvalues of each query point's tensor at each scale, in any order, >= 0
        up to round-off, NaN where the scale is undefined (``batch.counts`` 0)."""
        raise NotImplementedError(f"descriptor {self.name!r} gives neither eigenvalues nor saliency")

    def saliency(self, batch: NeighborhoodBatch) -> NDArray[np.float64]:
        """(B, S, 3) saliency maps (Cl, Cs, Cp) per scale; NaN rows where undefined. The
        eigenvalues are sorted descending and round-off negatives set to 0 first (docs/method.md, "Saliency map")."""
        return saliency_from_eigenvalues(descending(self.eigenvalues(batch), self.name))

    def params(self) -> dict[str, Any]:
        """Parameters recorded in result metadata."""
        return {}

    def prepare(self, xyz: NDArray[np.float64], kind: ScaleKind, scales: NDArray[Any], *, max_neighbors: int,
                min_neighbors: int, progress: bool | None = None) -> None:
        """Called once per cloud before the blocks, with the centred coordinates (input order)
        and the resolved scales; for descriptors that need cloud-wide passes. ``progress`` is
        the pipeline's progress setting (None: on a terminal only)."""

    def refine(self, batch: NeighborhoodBatch, saliency: NDArray[np.float64],
               pick: NDArray[np.int64] | None = None) -> NDArray[np.float64]:
        """Adjust the strategy's combined (B, 3) saliency of a block, given the strategy's
        chosen scale index per point (``pick``, -1 where undefined; None when the strategy
        chooses none, as Multiscale); identity by default."""
        return saliency


class Strategy:
    """Scale strategy: per-scale saliency maps -> one saliency map per point (docs/method.md, "Strategies").

    ``chooses_scale`` says whether :meth:`combine` picks one scale per point (an output of the
    run, e.g. Optimal-scale's OptimalScale); ``kernels`` as for :class:`Descriptor`.
    """

    name: ClassVar[str] = ""
    summary: ClassVar[str] = ""
    #: The scales a run takes unless it is given some.
    default_scales: ClassVar[Scales | None] = None
    chooses_scale: ClassVar[bool] = False
    kernels: ClassVar[Kernels] = ()

    def __repr__(self) -> str:
        return f"<strategy {self.name}>"

    def combine(self, per_scale: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.int64] | None]:
        """The (B, S, 3) saliency per scale -> ((B, 3) saliency, (B,) chosen scale index per
        point, -1 where undefined, or None when the strategy chooses none)."""
        raise NotImplementedError


def descending(ev: ArrayLike, name: str) -> NDArray[np.float64]:
    """Eigenvalues (..., 3) sorted l0 >= l1 >= l2 with round-off negatives set to 0 (docs/method.md, "Saliency map");
    LidarSigError naming descriptor ``name`` when they are not (..., 3) or clearly negative
    (below -ROUND_OFF times the tensor's largest magnitude). NaN rows stay NaN."""
    ev = np.asarray(ev, dtype=np.float64)
    if ev.ndim < 1 or ev.shape[-1] != 3:
        raise LidarSigError(f"descriptor {name!r} gave eigenvalues of shape {ev.shape}, not three per tensor; "
                            "fix the descriptor's eigenvalues()")
    from ..numerics.kernels import order_eigenvalues  # numba, loaded when saliency is first computed

    ev = np.ascontiguousarray(ev)
    out = np.empty_like(ev)
    rows = ev.reshape(-1, 3)
    wrong = order_eigenvalues(rows, out.reshape(-1, 3), ROUND_OFF)
    if wrong >= 0:
        row = np.sort(rows[wrong])[::-1]
        raise LidarSigError(f"descriptor {name!r} gave a negative eigenvalue ({row[2]:.6g} where the "
                            f"largest is {np.abs(row).max():.6g}): a tensor's eigenvalues must be >= 0 "
                            "(docs/method.md, Saliency map); fix the descriptor's eigenvalues()")
    return out
