"""Printing and exit status of tiled runs over a set of files, and the memory budget's choice
of tiles for one file (shared by the commands)."""
import contextlib
import warnings
from pathlib import Path

import click

from ..errors import LidarSigError, LidarSigWarning, counted
from ..io import LAS_EXTENSIONS


def is_set(sources, tiling, resume=False):
    """A set of tiles: several inputs, a folder, or any tiling option given (--tile-size,
    --workers, --scheduler); one file without them runs as one block unless it is over the
    memory budget (:func:`over_budget`)."""
    from ..tiling.run import tiles_asked

    return len(sources) > 1 or any(Path(s).is_dir() for s in sources) or resume or tiles_asked(tiling)


def over_budget(source, tiling, pipeline):
    """Points of one LAS/LAZ file that one block would hold above the memory budget (the
    command then runs it in tiles), from its header; None when it fits or is not LAS/LAZ. A
    descriptor that needs the whole cloud at once stays one block, with a note."""
    from ..tiling.core import tileable
    from ..tiling.memory import one_block_note, points_over_budget

    n = points_over_budget(source, tiling["memory"])
    if n is not None and not tileable(pipeline):
        warnings.warn(one_block_note(source, n, tiling["memory"], pipeline.descriptor.name), LidarSigWarning,
                      stacklevel=2)
        return None
    return n


def exceed(n, tiling):
    """"N points exceed the 1 GiB memory budget as one block", for the command's ``tiling``."""
    from ..tiling.memory import exceed as exceed_budget

    return exceed_budget(n, tiling["memory"])


def check_las_output(output, n, tiling):
    """Refuse a per-point output other than LAS/LAZ for a file processed in tiles."""
    if Path(output).suffix.lower() not in LAS_EXTENSIONS:
        what = f"{exceed(n, tiling)}; tiles" if n else "a file processed in tiles"
        raise LidarSigError(f"{what} write per-point results to LAS/LAZ only: give -o a .las or .laz name, or "
                            + ("raise --memory" if n else "leave out the tiling options"), path=output)


@contextlib.contextmanager
def scratch(output, work_dir):
    """The work folder of one file processed in tiles (``work_dir``, or a hidden folder beside
    ``output``), removed when the run ends, however it ends: such a run starts over."""
    from ..tiling.work import remove_work

    work = Path(work_dir) if work_dir else Path(output).with_name(f".{Path(output).name}.lidar-sig-work")
    try:
        yield work
    finally:
        remove_work(work)


def run_tiles(pipeline, sources, tiling, work, *, outputs=(), resume=False, quiet=False, over=None):
    """Run ``sources`` as a set with the command's tiling options; print the summary line.
    ``over``: the points of one file processed in tiles because of the memory budget (the line
    says why). Such a file runs on a worker per core, as a set does: two workers overlap their
    tiles' single-threaded parts (loading, grids, signatures), which took a 20M-point file from
    5.8 to 4.1 us per point on 2 cores (docs/performance.md)."""
    from ..tiling.execute import executor
    from ..tiling.run import run_set

    backend = executor(tiling["workers"], tiling["scheduler"])
    try:
        run = run_set(pipeline, sources, work=work, tile_size=tiling["tile_size"], backend=backend,
                      resume=resume, outputs=outputs, memory=tiling["memory"])
    finally:
        backend.close()
    if not quiet and run.tiling is not None:
        n = sum(s["n_points"] for s in run.tile_stats.values())
        recomputed = sum(s["n_recomputed"] for s in run.tile_stats.values())
        resumed = sum(bool(s.get("resumed")) for s in run.tile_stats.values())
        nx, ny = run.tiling.shape
        lost = f" ({len(run.failed_sources)} missing)" if run.failed_sources else ""
        excluded = sum(run.excluded.values())
        head = (f"{exceed(over, tiling)}: processed in {counted(len(run.tile_stats), 'tile')}" if over else
                f"set of {counted(len(run.sources), 'file')}{lost}: {counted(n, 'point')} in "
                f"{counted(len(run.tile_stats), 'tile')}")
        click.echo(f"{head} of {run.tiling.size:.4g} m ({nx} x {ny} grid"
                   + (f", {resumed} reused" if resumed else "") + f"), {counted(recomputed, 'point')} recomputed "
                   "with a wider halo"
                   + (f"; {counted(excluded, 'withheld or noise point')} left out" if excluded else ""))
        click.echo(f"{run.execution}: {run.seconds:.1f} s, {n / max(run.seconds, 1e-9):,.0f} points/s")
    return run


def check_complete(run, source):
    """Refuse the results of one file processed in tiles that lack some of its points."""
    if not run.complete:
        raise LidarSigError("could not be processed in tiles: " + "; ".join(run.missing), path=source)


def finish(run, work, written, not_written=()):
    """Exit status 1 naming what is missing, or 0 after removing the work folder."""
    if run.complete and not not_written:
        from ..tiling.work import remove_work

        remove_work(work)
        return
    for line in run.missing:
        click.echo(f"lidar-sig: missing: {line}", err=True)
    for line in not_written:
        click.echo(f"lidar-sig: not written: {line}", err=True)
    without = " (computed without the missing files' points)" if run.failed_sources and written else ""
    click.echo(f"lidar-sig: {counted(len(written), 'output')} written{without}; the run is incomplete (work kept in {work}): "
               "fix or replace the files above and run the same command with --resume", err=True)
    raise click.exceptions.Exit(1)


def output_name(outdir, source):
    """Per-point output of one input file: its name, in ``outdir`` (LAS stays LAS, LAZ LAZ)."""
    p = Path(source.path)
    return Path(outdir) / (p.name if p.suffix.lower() in LAS_EXTENSIONS else p.stem + ".laz")
