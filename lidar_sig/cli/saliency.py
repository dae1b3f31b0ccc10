"""`lidar-sig saliency`: per-point saliency written as LAS/LAZ extra dimensions."""
import time
from pathlib import Path

import click

from ..errors import LidarSigError
from ..io import LAS_EXTENSIONS, check_output, read
from . import cli
from .options import overwrite_option, pipeline_options
from .report import echo_run


@cli.command()
@click.argument("source")
@click.option("-o", "--output", required=True, help="Output LAS/LAZ file.")
@overwrite_option
@pipeline_options
def saliency(source, output, overwrite, pipeline, quiet):
    """Write SOURCE with extra dimensions Cl, Cs, Cp, Egeom, GeomClass (and OptimalScale)."""
    if Path(output).suffix.lower() not in LAS_EXTENSIONS:
        raise LidarSigError("output must be .las or .laz", path=output)
    check_output(output, overwrite=overwrite)
    start = time.perf_counter()
    cloud = read(source)
    result = pipeline.run(cloud)
    result.write(output, overwrite=overwrite)
    if not quiet:
        echo_run(source, result)
        click.echo(f"wrote {output} in {time.perf_counter() - start:.1f} s")
