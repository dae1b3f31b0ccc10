"""`lidar-sig saliency`: per-point saliency written as LAS/LAZ extra dimensions."""
import time
from pathlib import Path

import click

from ..errors import LidarSigError
from ..io import CLOUD_EXTENSIONS, check_cloud_output, check_output, read
from . import cli
from .options import columns_option, overwrite_option, pipeline_options
from .report import echo_run


@cli.command()
@click.argument("source")
@click.option("-o", "--output", required=True,
              help="Output point cloud: LAS/LAZ (extra dimensions), PLY/PCD (attributes) or text (columns).")
@overwrite_option
@columns_option
@pipeline_options
def saliency(source, output, overwrite, columns, pipeline, method_given, quiet):
    """Write SOURCE with per-point Cl, Cs, Cp, Egeom, GeomClass (and OptimalScale)."""
    if Path(output).suffix.lower() not in CLOUD_EXTENSIONS:
        raise LidarSigError(f"output must be a point cloud: {', '.join(CLOUD_EXTENSIONS)}", path=output)
    check_output(output, overwrite=overwrite)
    start = time.perf_counter()
    cloud = read(source, columns=columns)
    check_cloud_output(output, cloud)  # before the work, not after
    result = pipeline.run(cloud)
    result.write(output, overwrite=overwrite)
    if not quiet:
        echo_run(source, result)
        click.echo(f"wrote {output} in {time.perf_counter() - start:.1f} s")
