"""A change map made and written (``lidar-sig changes``; docs/commands/changes.md): every output
checked before any work, then all written together or none."""
from __future__ import annotations

import contextlib
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ..base.errors import LidarSigError, whole_number, yes_no
from ._common import JobRun


@dataclass(repr=False)
class ChangesRun(JobRun):
    """What :func:`changes` did (:class:`JobRun`): the ChangeMap (two epochs) or ChangeSeries
    (more) and the files written (``lines`` say so)."""

    changes: Any = None
    top: int = 10

    def to_dict(self) -> dict[str, Any]:
        return {**self.changes.to_dict(self.top), "written": list(self.written)}


def changes(epochs: Any, *, output: Any = None, cells: Any = None, points: Any = None, png: Any = None,
            report: Any = None, overwrite: bool = False, top: int = 10, execution: Any = None, resume: bool = False,
            **options: Any) -> ChangesRun:
    """The change map of ``epochs`` (two or more, in time order; :func:`lidar_sig.changes`, which
    takes ``options``: cell, min_points, score, confidence, class_map, pipeline, render,
    columns) written as the GeoTIFF ``output`` (with its QGIS style beside it), the cells'
    GeoPackage ``cells``, the later epoch's points with their cell's change ``points`` (two
    epochs), the map ``png`` and the HTML ``report``; ``top`` cells in its JSON. Two epochs of
    LAS/LAZ files above the memory budget of ``execution`` (or with tiles, workers or a
    scheduler asked) are mapped in work units, with their work folder beside the first output
    (or ``execution.work_dir``), kept after an interruption for ``resume`` and removed once the
    outputs are written."""
    from ..change_map import changes as change_map
    from ..change_map import in_units
    from ..change_map import check_streamed
    from ..pipeline.flow import pipeline_or_default
    from ..io import output_group
    from ..io.styles import style_path
    from ..tiling.execution import as_execution
    from ..tiling.work import work_scope

    overwrite, resume = yes_no(overwrite, "overwrite"), yes_no(resume, "resume")
    top = whole_number(top, "top (the cells listed)")
    epochs = list(epochs) if isinstance(epochs, (list, tuple)) else [epochs]
    if len(epochs) < 2:
        raise LidarSigError("give at least two epochs (A B), in time order")
    if points and len(epochs) > 2:
        from ..change_map.series import POINTS_OF_TWO

        raise LidarSigError(POINTS_OF_TWO, path=points)
    check_outputs(output, png, report, overwrite, cells, points, inputs=epochs)
    execution = as_execution(execution)
    files = in_units(epochs, execution, pipeline_or_default(options.get("pipeline")), resume)
    if files is not None:
        outputs = [p for p in (output, output and style_path(output), cells, points, png, report) if p]
        options.update(work=_work(execution, outputs))
        if points:
            check_streamed(points, len(files[1]), epochs[1])
    # in work units, the outputs are written within the work folder's scope: an output that
    # cannot be written (a full disk) leaves the folder as any failure does, named for --resume
    with work_scope(options["work"]) if files is not None else contextlib.nullcontext():
        result = change_map(*epochs, execution=execution, resume=resume, **options)
        done = ChangesRun(changes=result, top=top)
        with output_group():  # all or none
            for path in (output, cells, points, png, report):
                if path:
                    result.save(path, overwrite=overwrite)
                    done.written.append(str(path))
                    style = style_path(path) if str(path).lower().endswith((".tif", ".tiff")) else None
                    done.lines.append(f"wrote {path}" + (f" (style {style})" if style else ""))
        if files is not None:
            result.close()  # written: the work folder goes
    return done


def _work(execution: Any, outputs: list[Any]) -> Path:
    """The work folder of a change map in work units: the execution's ``work_dir``, else beside
    the first output (on its file system), else in the working folder (where a resumed run
    finds it again); refused when it would hold an output, as it goes once they are written."""
    from ..base.errors import arg
    from ._common import work_folder

    first = Path(outputs[0]) if outputs else None
    work = work_folder(execution, first.with_name(f".{first.name}.lidar-sig-work") if first
                       else Path(".lidar-sig-changes-work"))
    for p in outputs:
        if work.resolve() in Path(p).resolve().parents:
            raise LidarSigError(f"would hold {p}, but the work folder is removed after the run; give "
                                f"{arg('work_dir')} a folder of its own", path=work)
    return work


def check_outputs(output: Any, png: Any, report: Any, overwrite: bool, cells: Any = None, points: Any = None,
                  inputs: Any = ()) -> None:
    """Refuse every output of a change map that cannot be written, before anything is computed,
    and one that is an epoch's file or that an epoch's folder or pattern would read (``inputs``)."""
    from ..base.errors import as_path
    from ..io import check_outputs as check_paths
    from ..io.formats import IMAGE, POINTS, VECTOR, check_format
    from ..io.geotiff import check_geotiff_output
    from ..io.styles import style_path
    from ..io.tile_lists import check_apart
    from ..reporting import check_report_path

    said = {"output": output, "cells": cells, "points": points, "png": png, "report": report}
    for what, path in said.items():
        if path is not None:
            as_path(path, what)  # output=5 is named at this call
    paths = [p for p in (output, output and style_path(output), cells, points, png, report) if p]
    check_paths(paths, overwrite=overwrite)
    check_apart(paths, list(inputs))
    if output:
        check_geotiff_output(output, overwrite=overwrite)
    if cells:
        check_format(cells, VECTOR, said="the cells")
    if points:
        check_format(points, POINTS, said="the points with their cell's change")
    if png:
        check_format(png, IMAGE, said="the map")
    if report:
        check_report_path(report, overwrite=overwrite)

