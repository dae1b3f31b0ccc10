"""Printing and exit status of tiled runs over a set of files (shared by the commands)."""
from pathlib import Path

import click

from ..errors import counted
from ..io import LAS_EXTENSIONS


def is_set(sources, tiling, resume=False):
    """A set of tiles: several inputs, a folder, or any tiling option given; one file without
    them runs as one block, as before."""
    return (len(sources) > 1 or any(Path(s).is_dir() for s in sources) or resume
            or any(v is not None for v in tiling.values()))


def run_tiles(pipeline, sources, tiling, work, *, outputs=(), resume=False, quiet=False):
    """Run ``sources`` as a set with the command's tiling options; print the summary line."""
    from ..tiling.execute import executor
    from ..tiling.run import run_set

    backend = executor(tiling["workers"], tiling["scheduler"])
    try:
        run = run_set(pipeline, sources, work=work, tile_size=tiling["tile_size"], backend=backend,
                      resume=resume, outputs=outputs)
    finally:
        backend.close()
    if not quiet and run.tiling is not None:
        n = sum(s["n_points"] for s in run.tile_stats.values())
        recomputed = sum(s["n_recomputed"] for s in run.tile_stats.values())
        resumed = sum(bool(s.get("resumed")) for s in run.tile_stats.values())
        nx, ny = run.tiling.shape
        lost = f" ({len(run.failed_sources)} missing)" if run.failed_sources else ""
        excluded = sum(run.excluded.values())
        click.echo(f"set of {counted(len(run.sources), 'file')}{lost}: {counted(n, 'point')} in "
                   f"{counted(len(run.tile_stats), 'tile')} of {run.tiling.size:.4g} m ({nx} x {ny} grid"
                   + (f", {resumed} reused" if resumed else "") + f"), {counted(recomputed, 'point')} recomputed "
                   "with a wider halo"
                   + (f"; {counted(excluded, 'withheld or noise point')} left out" if excluded else ""))
        click.echo(f"{run.execution}: {run.seconds:.1f} s, {n / max(run.seconds, 1e-9):,.0f} points/s")
    return run


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
