"""The inputs of a comparison as compared (:class:`Side`), and their reading: an archive loaded,
a cloud read and run, a folder of tiles (or a file over the memory budget) run as one set, a
cloud compared with an archive computed the archive's way."""
from __future__ import annotations

import warnings
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ..base.errors import LidarSigError, LidarSigWarning, a_kind, arg, counted
from ..method.cloud import PointCloud
from ..method.scales import ScaleKind, recorded_kind
from ..method.signature_raster import Signature, method_differences

if TYPE_CHECKING:
    from ..pipeline.flow import Pipeline
    from ..tiling.execution import Execution


@dataclass
class Side:
    """One input of a comparison: where it came from, its signature and, for a cloud, the run."""

    name: str
    signature: Signature
    result: object = None  # pipeline Result for a cloud, None for an archive or a set of tiles
    tiled: bool = False  # computed as a set of tiles (a folder, or a file over the memory budget)
    in_memory: bool = False  # a Signature given as it is, not read from an archive file

    @property
    def kind(self) -> str:
        """"cloud", "set of tiles", "archive" (a signature file) or "signature" (given in memory)."""
        if self.result is not None:
            return "cloud"
        return "set of tiles" if self.tiled else "signature" if self.in_memory else "archive"

    def summary(self) -> dict[str, Any]:
        """The side's facts for people and JSON: points, undefined, capped, duplicates, withheld
        or noise points left out (excluded), scales, units."""
        m = self.signature.metadata
        return {"path": self.name, "kind": self.kind, "points": int(m.get("n_points", self.signature.n_points)),
                "undefined": int(m.get("n_undefined", self.signature.n_undefined)),
                "capped": int(m.get("n_capped", 0)), "duplicates": int(m.get("n_duplicates", 0)),
                "excluded": int(m.get("n_excluded", 0)),
                "scale_kind": m.get("scale_kind"), "scales": list(m.get("resolved_scales", [])),
                "scales_unit": (recorded_kind(m) or ScaleKind.RADIUS).unit,
                "units": m.get("units", "unknown")}


def side_of(x: Any, pipeline: Pipeline | None = None, columns: str | Sequence[str] | None = None) -> Side:
    """The :class:`Side` of one input: a pipeline Result as it is, an archive loaded, a cloud
    read and run through ``pipeline`` (default ``Pipeline()``)."""
    from ..pipeline.flow import Pipeline
    from ..pipeline.result import Result

    if isinstance(x, Result):
        return Side(input_name(x), x.signature, x)
    loaded = load_input(x, columns)
    if isinstance(loaded, Signature):
        return Side(input_name(x), loaded, in_memory=isinstance(x, Signature))
    result = (pipeline or Pipeline()).run(loaded)
    return Side(input_name(x), result.signature, result)


def input_name(x: Any) -> str:
    """The name an input is shown under: its path, a signature's or result's source, or "(in
    memory)"."""
    from ..pipeline.result import Result

    if isinstance(x, (str, Path)):
        return str(x)
    if isinstance(x, Result):
        return x.metadata.get("source") or "(in memory)"
    return getattr(x, "path", None) or (x.metadata.get("source") if isinstance(x, Signature) else None) or "(in memory)"


def load_input(x: Any, columns: str | Sequence[str] | None = None, as_set: bool = False,
               what: str = "the input") -> PointCloud | Signature | Path:
    """An input made ready to compare: a PointCloud or Signature as it is, an archive (.h5)
    loaded, a cloud file read (``columns`` of a text file), a folder of tiles (or, with
    ``as_set``, a LAS/LAZ file) as a Path to process as one set."""
    from ..io import HDF5_EXTENSIONS, LAS_EXTENSIONS, load_signature, read
    from ..io.tile_lists import tile_list

    from ..pipeline.result import Result

    if isinstance(x, (PointCloud, Signature)):
        return x
    if isinstance(x, Result):  # computed already: its signature
        return x.signature
    if isinstance(x, (str, Path)):
        listed = tile_list(x)  # a glob pattern or .vpc of several tiles is a set, as a folder is
        if Path(x).is_dir() or (as_set and Path(x).suffix.lower() in LAS_EXTENSIONS) or (listed and len(listed) > 1):
            return Path(x)  # processed as a set of tiles
        if Path(x).suffix.lower() in HDF5_EXTENSIONS:
            return load_signature(x)
        return read(x, columns=columns)
    raise LidarSigError(f"{what} is {a_kind(x)}: give a file path, a PointCloud, a Signature or a Result to compare")


def holds_signature(x: Any) -> bool:
    """Whether ``x`` is a signature, a result or an archive file (.h5) rather than points."""
    from ..io import HDF5_EXTENSIONS
    from ..pipeline.result import Result

    return (isinstance(x, (Signature, Result))
            or isinstance(x, (str, Path)) and not Path(x).is_dir() and Path(x).suffix.lower() in HDF5_EXTENSIONS)


def archive_pipeline(signature: Signature, pipeline: Pipeline, method_given: Iterable[str], name: str) -> Pipeline:
    """The pipeline that made an archive, for the cloud compared with it; refuses options the
    user set that contradict it."""
    from ..pipeline.flow import Pipeline

    recorded = {k: signature.metadata[k] for k in signature.metadata if k in pipeline.method()}
    whole = "pipeline" in method_given  # Python: the pipeline given, all of it
    if (whole or "classes" in method_given) and signature.classes.names and pipeline.classes != signature.classes:
        raise LidarSigError(f"{name} is an archive made with class table {signature.classes.name!r}, not "
                            f"{pipeline.classes.name!r}; leave out {arg('pipeline' if whole else 'classes')} or make "
                            "the archive again with it")
    if set(method_given) - {"classes"}:
        differ = method_differences(recorded, pipeline.method())
        if differ:
            raise LidarSigError(f"{name} is an archive made with another method (" + "; ".join(differ)
                                + f"); leave out {arg('pipeline') if whole else 'the method options'} to compute "
                                "the cloud the archive's way")
    return Pipeline.from_method(recorded, classes=signature.classes, frame=signature.frame,
                                progress=pipeline.progress)


def unlabelled_pipeline(pipeline: Pipeline) -> Pipeline:
    """``pipeline`` with every point in one class: a run as of a cloud without labels (no
    class is noise then, withheld points are still left out)."""
    import copy

    from ..method.classes import UNLABELED

    pipe = copy.copy(pipeline)
    pipe.classes = UNLABELED
    return pipe


def signature_of_set(folder: Path, pipeline: Pipeline, execution: Execution,
                     over: int | None = None) -> tuple[Signature, bool]:
    """The signature of a folder of LAS/LAZ tiles (or one LAS/LAZ file) processed as one set,
    with scratch files in a new folder inside the execution's ``work_dir`` or the temporary
    folder (``TMPDIR``), removed after the run, and whether its points are labelled; refuses an incomplete set. ``over``: the
    points of one file processed in tiles because of the memory budget (a note says so)."""
    from ..tiling.memory import exceed
    from ..tiling.run_set import run_set
    from ..tiling.work import discard_work, fresh_work

    work = fresh_work(execution.work_dir)
    try:
        with execution.backend() as backend:
            run = run_set(pipeline, [folder], work=work, tile_size=execution.tile_size, backend=backend,
                          memory=execution.memory)
    finally:
        discard_work(work)
    if not run.complete:
        raise LidarSigError("the set is incomplete, its signature would lack points: " + "; ".join(run.missing),
                            path=folder)
    if over:
        warnings.warn(f"{folder}: {exceed(over, int(execution.memory))}: processed in "
                      f"{counted(len(run.tile_stats), 'tile')}", LidarSigWarning, stacklevel=3)
    run.signature.metadata["tiling"] = run.tiling_record()
    return run.signature, run.labelled
