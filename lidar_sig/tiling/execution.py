"""How a job runs: :class:`Execution`, the memory budget of each process (which decides whether a
LAS/LAZ file runs as one block or in tiles) and, for work in tiles, their size, where they run
(this process, local processes, a Dask cluster) and where their scratch files go
(docs/scale-out.md). Every face passes one: the command line builds it from ``--memory``,
``--tile-size``, ``--workers``, ``--scheduler`` and ``--work-dir``; Python gives it to
``Pipeline.run`` and to the jobs of :mod:`lidar_sig.jobs`, or takes the default.
"""
from __future__ import annotations

import contextlib
import os
import warnings
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ..base.errors import LidarSigError, LidarSigWarning, a_kind, arg, check_name_lengths, positive_metres, whole_number
from .memory import DEFAULT_MEMORY, budget_bytes, one_block_note, points_over_budget, size

#: Most local worker processes per core: above the cores, workers take turns on them while each
#: holds its own memory (docs/scale-out.md has the measurement), so a few
#: per core are allowed (with a note) and more are refused (docs/scale-out.md, "Options").
WORKERS_PER_CORE = 4


@dataclass(frozen=True)
class Execution:
    """How a job runs.

    Parameters
    ----------
    memory : int or str
        Memory budget of each process: bytes (an int, a numpy integer or a bare number in
        text), or a size such as ``"1GiB"``, ``"800MiB"``, ``"1.5G"``, ``"500B"`` (binary
        units; B is bytes); default 1 GiB; above this machine's memory, taken with a note. A LAS/LAZ file that needs more as one block
        is processed in tiles sized to it (docs/performance.md has the model).
    tile_size : float, optional
        Side of the processing tiles in metres; given, a set of files or a file is processed
        in tiles whatever its size.
    workers : int, optional
        Local worker processes of a run in tiles (default: one per core; 1: this process
        alone); more than the cores is said in a note, more than 4 per core refused.
    scheduler : str, optional
        Address of a dask.distributed scheduler (``tcp://host:8786``) to run the tiles on
        instead of local processes (needs the dask extra).
    work_dir : str or Path, optional
        Scratch folder of a run in tiles, seen by every worker at this path (default: beside
        the output); for a result kept in Python (``Pipeline.run``, ``compare``), a folder that
        exists, in which each run makes its own (default: the temporary folder).
    """

    memory: int | str = DEFAULT_MEMORY
    tile_size: float | None = None
    workers: int | None = None
    scheduler: str | None = None
    work_dir: str | os.PathLike[str] | None = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "memory", budget_bytes(self.memory))
        if self.tile_size is not None:
            object.__setattr__(self, "tile_size", positive_metres(self.tile_size, arg("tile_size")))
        if self.workers is not None:
            object.__setattr__(self, "workers", _checked_workers(self.workers))
        if self.scheduler is not None and (not isinstance(self.scheduler, str) or not self.scheduler.strip()):
            raise LidarSigError(f"{arg('scheduler')} must be an address such as tcp://host:8786, got "
                                f"{a_kind(self.scheduler) if not isinstance(self.scheduler, str) else 'an empty text'}")
        if self.scheduler is not None:  # " tcp://host:8786 " as the command line takes it
            object.__setattr__(self, "scheduler", self.scheduler.strip())
        if self.scheduler and self.workers:
            raise LidarSigError(f"give {arg('workers')} or {arg('scheduler')}, not both (the cluster has its own workers)")
        if self.work_dir is not None:
            if not isinstance(self.work_dir, (str, os.PathLike)) or not str(self.work_dir):
                got = "an empty path" if isinstance(self.work_dir, str) else a_kind(self.work_dir)
                raise LidarSigError(f"{arg('work_dir')} must be a folder path, got {got}")
            check_name_lengths(self.work_dir)
            object.__setattr__(self, "work_dir", Path(self.work_dir))

    def __repr__(self) -> str:
        from ..base.views import one_line

        where = (f"Dask {self.scheduler}" if self.scheduler else "all cores" if self.workers is None
                 else f"{self.workers} process{'es' if self.workers > 1 else ''}")
        tiles = f", tiles of {self.tile_size:g} m" if self.tile_size else ""
        work = f", work in {self.work_dir}" if self.work_dir else ""
        return one_line(f"<Execution {size(int(self.memory))} per process, {where}{tiles}{work}>")

    @property
    def tiles_asked(self) -> bool:
        """True when tiles are asked for whatever the size: a tile size, workers or a
        scheduler given (the memory budget alone decides by the size)."""
        return self.tile_size is not None or self.workers is not None or self.scheduler is not None

    def over_budget(self, source: Any, pipeline: Any) -> int | None:
        """The points of ``source`` when one block of them would need more than the memory
        budget, so that the job runs it in tiles; None when it fits, when it is not a LAS/LAZ
        file (its size is known only once read), or when the descriptor needs the whole cloud
        at once (a note then says it runs as one block after all). The one place where a job
        chooses between one block and tiles."""
        if not isinstance(source, (str, os.PathLike)):
            return None
        n = points_over_budget(source, int(self.memory))
        if n is not None and not pipeline.descriptor.tileable:
            warnings.warn(one_block_note(source, n, int(self.memory), pipeline.descriptor.name), LidarSigWarning,
                          stacklevel=3)
            return None
        return n

    @contextlib.contextmanager
    def backend(self) -> Iterator[Any]:
        """Where the tiles run (:mod:`lidar_sig.tiling.backends`), closed when the block ends."""
        from .backends import executor

        backend = executor(self.workers, self.scheduler)
        try:
            yield backend
        finally:
            backend.close()


def _checked_workers(workers: Any) -> int:
    """``workers`` as an int: a whole number from 1 to :data:`WORKERS_PER_CORE` per core of this
    machine (LidarSigError naming the value, the cores and the fix otherwise), with a note when
    it is more than the cores."""
    from .backends import cores

    workers = whole_number(workers, arg("workers"), low=1)
    n_cores = cores()
    most = WORKERS_PER_CORE * n_cores
    if workers > most:
        raise LidarSigError(f"{arg('workers', workers)} is more than {WORKERS_PER_CORE} per core of this machine "
                            f"({n_cores} cores: at most {most}); workers beyond the cores only take turns on them, "
                            f"each holding its own memory: give at most {n_cores}, or leave it out for one per core")
    if workers > n_cores:
        warnings.warn(f"{arg('workers', workers)} is more than the {n_cores} cores of this machine: the workers "
                      f"take turns on them, each holding its own memory; a run is fastest with at most {n_cores}",
                      LidarSigWarning, stacklevel=4)  # the call of Execution(...)
    return workers


def as_execution(execution: Execution | None) -> Execution:
    """``execution``, or the default for None; a LidarSigError naming anything else."""
    if execution is None:
        return Execution()
    if not isinstance(execution, Execution):
        raise LidarSigError(f"execution must be a lidar_sig.Execution, got {a_kind(execution)}")
    return execution
