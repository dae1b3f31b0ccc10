"""`lidar-sig signature`: the signature image of a cloud."""
from pathlib import Path

import click

from ..errors import LidarSigError
from ..io import check_output, read
from ..render import write_signature_png
from . import cli
from .options import overwrite_option, pipeline_options
from .report import echo_run


@cli.command()
@click.argument("source")
@click.option("-o", "--output", required=True, help="PNG of the augmented semantic signature Sas.")
@click.option("--sg", "sg_output", default=None, help="Also write the geometric signature Sg as PNG.")
@click.option("--mode", type=click.Choice(["density", "points"]), default="density", show_default=True,
              help="Rendering: per-pixel point share (density) or the paper's point marks.")
@overwrite_option
@pipeline_options
def signature(source, output, sg_output, mode, overwrite, pipeline, quiet):
    """Render the signature of SOURCE (Sas, and Sg with --sg) as PNG."""
    for path in filter(None, (output, sg_output)):
        if Path(path).suffix.lower() != ".png":
            raise LidarSigError("signature images are written as .png", path=path)
        check_output(path, overwrite=overwrite)
    result = pipeline.run(read(source))
    write_signature_png(output, result.signature, kind="sas", mode=mode, overwrite=overwrite)
    if sg_output:
        write_signature_png(sg_output, result.signature, kind="sg", mode=mode, overwrite=overwrite)
    if not quiet:
        echo_run(source, result)
        click.echo(f"wrote {', '.join(filter(None, (output, sg_output)))}")
