"""What the jobs share: whether inputs make a set of tiles, their output checks, the work folder
of a set, and the facts every job result gives (lines for people, a dict for JSON)."""
from __future__ import annotations

import os
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, TypeAlias

from ..base.errors import LidarSigError, a_kind, arg, as_path

if TYPE_CHECKING:
    from ..tiling.execution import Execution

#: A path as the jobs take it.
PathLike: TypeAlias = "str | os.PathLike[str]"
#: Inputs of a job: one file or folder, or a list of them.
Sources: TypeAlias = "str | os.PathLike[str] | Sequence[str | os.PathLike[str]]"
#: The columns of a text cloud: ``"x,y,z,-,label"`` or a list of names.
Columns: TypeAlias = "str | Sequence[str] | None"


def as_sources(sources: Sources, what: str = "sources") -> list[str]:
    """``sources`` as a list of paths: one path, or a list or tuple of them (not empty)."""
    if isinstance(sources, (str, os.PathLike)):
        sources = [sources]
    if not isinstance(sources, (list, tuple)) or not sources:
        raise LidarSigError(f"{what} must be a file or folder path or a list of them, got "
                            + ("an empty list" if isinstance(sources, (list, tuple)) else a_kind(sources)))
    from ..io.tile_lists import tile_list

    out: list[str] = []
    for s in sources:  # a glob pattern or .vpc stands for its tiles, as in changes and catalog
        listed = tile_list(as_path(s, what))
        out += [str(s)] if listed is None else [str(p) for p in listed]
    return out


def is_set(sources: list[str], execution: Execution, resume: bool = False) -> bool:
    """A set of tiles: several inputs, a folder, a resumed run, or tiles asked for
    (``execution.tiles_asked``); one file otherwise, run as one block unless the memory budget
    says otherwise (:meth:`lidar_sig.Execution.over_budget`)."""
    return len(sources) > 1 or any(Path(s).is_dir() for s in sources) or resume or execution.tiles_asked


def work_folder(execution: Execution, default: Path) -> Path:
    """The work folder of a job in tiles: the execution's ``work_dir``, else ``default`` (beside
    or inside the output: on its file system, where room for it is expected)."""
    return Path(execution.work_dir) if execution.work_dir is not None else Path(default)


@dataclass
class JobRun:
    """What a job did: the outputs ``written``, those ``not_written`` (a line each, why), what is
    ``missing`` (a line each: inputs or tiles that failed), the work folder kept for a resumed
    run (``work``, when incomplete) and how long it took. ``lines`` are what the command prints
    on stdout, :meth:`to_dict` what ``--json`` prints."""

    written: list[str] = field(default_factory=list)
    not_written: list[str] = field(default_factory=list)
    missing: list[str] = field(default_factory=list)
    work: str | None = None
    seconds: float = 0.0
    lines: list[str] = field(default_factory=list)

    @property
    def complete(self) -> bool:
        """True when every input was processed and every output written."""
        return not self.missing and not self.not_written

    def problems(self) -> list[str]:
        """The lines that say what is missing and what to do (stderr of an incomplete run)."""
        from ..base.errors import counted, printable

        if self.complete:
            return []
        out = [f"missing: {line}" for line in self.missing] + [f"not written: {line}" for line in self.not_written]
        fix = "fix or replace the files above and run the same job again"
        again = f" (work kept in {self.work}): {fix} with {arg('resume', True)}" if self.work else f": {fix}"
        out.append(f"{counted(len(self.written), 'output')} written; the run is incomplete{again}")
        return [printable(line) for line in out]  # one line each, whatever the file names

    def to_dict(self) -> dict[str, Any]:
        return {"written": list(self.written), "not_written": list(self.not_written), "missing": list(self.missing),
                "complete": self.complete, "work": self.work, "seconds": round(self.seconds, 3)}

    def __repr__(self) -> str:
        state = "complete" if self.complete else f"incomplete, {len(self.missing) + len(self.not_written)} problems"
        from ..base.views import one_line

        # the paths as given: where a run wrote is what its record is for
        shown = ", ".join(self.written[:2]) + (f", ... ({len(self.written)})" if len(self.written) > 2 else "")
        return one_line(f"<{type(self).__name__} {state}; wrote {shown or 'nothing'}>")

