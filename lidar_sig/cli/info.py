"""`lidar-sig info`: what a signature archive or a point-cloud file holds."""
from pathlib import Path

import click

from ..errors import counted
from ..io import HDF5_EXTENSIONS, read
from .group import cli
from .options import columns_option


@cli.command()
@click.argument("path")
@columns_option
def info(path, columns):
    """Summarize a signature archive or survey catalogue (.h5), or a point-cloud file."""
    if Path(path).suffix.lower() in HDF5_EXTENSIONS:
        from ..io import archive_summary
        from ..io.catalog import is_catalog

        if is_catalog(path):
            from ..catalog import Catalog

            click.echo("\n".join(Catalog(path).summary()))
            return
        click.echo("\n".join(archive_summary(path)))
        return
    import numpy as np

    cloud = read(path, columns=columns)
    lo, hi = cloud.xyz.min(axis=0), cloud.xyz.max(axis=0)
    click.echo(f"{path}: {counted(len(cloud), 'point')}")
    click.echo("  bounds " + ", ".join(f"{a} {l:.2f} .. {h:.2f}" for a, l, h in zip("xyz", lo, hi)))
    las = cloud.source
    if las is not None and hasattr(las, "header"):
        h = las.header
        click.echo(f"  LAS {h.version}, point format {h.point_format.id}, "
                   f"dimensions {', '.join(h.point_format.dimension_names)}")
        crs = [type(v).__name__ for v in h.vlrs if "Coordinate" in type(v).__name__ or "GeoKey" in type(v).__name__]
        click.echo(f"  CRS record: {', '.join(crs) if crs else 'none'}")
    if cloud.withheld is not None:
        click.echo(f"  withheld: {counted(int(cloud.withheld.sum()), 'point')} (left out of runs unless --keep-noise)")
    if cloud.labels is None:
        click.echo("  labels: none")
    else:
        codes, counts = np.unique(cloud.labels, return_counts=True)
        click.echo("  labels: " + ", ".join(f"{c}: {n:,}" for c, n in zip(codes, counts)))
