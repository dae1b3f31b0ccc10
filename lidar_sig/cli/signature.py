"""`lidar-sig signature`: the signature of a cloud, as an HDF5 archive or a PNG image."""
from pathlib import Path

import click

from ..errors import LidarSigError
from ..io import HDF5_EXTENSIONS, check_outputs, output_group, read
from ..render import write_signature_png
from . import cli
from ..signature import RENDERINGS
from .options import columns_option, overwrite_option, pipeline_options, render_option
from .report import echo_run


@cli.command()
@click.argument("source")
@click.option("-o", "--output", required=True,
              help="Signature archive (.h5) or image of the augmented semantic signature Sas (.png).")
@click.option("--png", "png_output", default=None, help="Also write Sas as PNG (with an .h5 output).")
@click.option("--sg", "sg_output", default=None, help="Also write the geometric signature Sg as PNG.")
@click.option("--no-points", is_flag=True, help="Leave the per-point datasets out of the archive.")
@render_option
@overwrite_option
@columns_option
@pipeline_options
def signature(source, output, png_output, sg_output, no_points, render, overwrite, columns, pipeline,
              method_given, quiet):
    """Compute the signature of SOURCE; write it as an archive (.h5) and/or images (.png)."""
    ext = Path(output).suffix.lower()
    if ext not in HDF5_EXTENSIONS + (".png",):
        raise LidarSigError("the signature is written as .h5 (archive) or .png (image)", path=output)
    images = [p for p in (png_output, sg_output) if p]
    for path in images:
        if Path(path).suffix.lower() != ".png":
            raise LidarSigError("signature images are written as .png", path=path)
    check_outputs([output] + images, overwrite=overwrite)  # all of them, before any work
    render = render or RENDERINGS[0]
    result = pipeline.run(read(source, columns=columns))
    with output_group():  # all outputs or none
        if ext == ".png":
            write_signature_png(output, result.signature, kind="sas", mode=render, overwrite=overwrite)
        else:
            result.write(output, overwrite=overwrite, points=not no_points, render=render)
        if png_output:
            write_signature_png(png_output, result.signature, kind="sas", mode=render, overwrite=overwrite)
        if sg_output:
            write_signature_png(sg_output, result.signature, kind="sg", mode=render, overwrite=overwrite)
    if not quiet:
        echo_run(source, result)
        click.echo(f"wrote {', '.join([output] + images)}")
