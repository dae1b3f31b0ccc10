"""A job's HTML report and its figures: checked before the work, written together."""
from __future__ import annotations

from collections.abc import Callable, Iterable
from typing import Any

from ._common import PathLike


def check_report_outputs(report: PathLike | None, plots: PathLike | None, names: Iterable[str],
                         overwrite: bool) -> None:
    """Refuse report and plot outputs that cannot be written, before anything is computed
    (``names``: the figures' file names in the plots folder)."""
    from ..io import check_outputs
    from ..reporting import check_plots_folder, check_report_path

    if report:
        check_outputs([report], overwrite=overwrite)
        check_report_path(report, overwrite=overwrite)
    if plots:
        check_plots_folder(plots, names, overwrite=overwrite)


def write_report(make: Callable[[], Any], report: PathLike | None, plots: PathLike | None,
                 overwrite: bool) -> tuple[list[str], list[str]]:
    """Write the report ``make()`` makes as ``report`` and its figures in ``plots``, all files or
    none; the paths written and the lines saying so."""
    from ..io import output_group

    made = make()
    written, lines = [], []
    with output_group():
        if report:
            made.save(report, overwrite=overwrite)
            written.append(str(report))
            lines.append(f"wrote {report}")
        if plots:
            n = len(made.save_plots(plots, overwrite=overwrite))
            written.append(str(plots))
            lines.append(f"wrote {n} plots in {plots}")
    return written, lines
