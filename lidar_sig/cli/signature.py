"""`lidar-sig signature`: the signature of a cloud, as an HDF5 archive, PNG images or a report."""
import click

from .options import (aoi_option, crs_option, columns_option, execution_options, json_option, not_empty, overwrite_option, pipeline_options,
                      render_option, report_options, resume_option)
from .summaries import show


@click.command()
@click.argument("sources", nargs=-1, required=True)
@click.option("-o", "--output", default=None,
              help="Signature archive (.h5) or image of the augmented semantic signature Sas (.png).")
@click.option("--png", "png_output", default=None, callback=not_empty("a file name"),
              help="Also write Sas as PNG (with an .h5 output).")
@click.option("--sg", "sg_output", default=None, callback=not_empty("a file name"),
              help="Also write the geometric signature Sg as PNG.")
@click.option("--no-points", is_flag=True, help="Leave the per-point datasets out of the archive.")
@report_options
@render_option
@overwrite_option
@columns_option
@crs_option
@execution_options
@resume_option
@json_option
@aoi_option
@pipeline_options
def signature(sources, output, png_output, sg_output, no_points, report, plots, render, overwrite, columns, crs,
              execution, resume, as_json, aoi, pipeline, method_given, quiet):
    """Compute the signature of SOURCES; write it as an archive (.h5), images (.png) and/or an
    HTML report (--report).

    One file is processed as one block, or in tiles with halos when one block would need more
    memory than --memory. Several files, folders of LAS/LAZ tiles, or any of --tile-size,
    --workers, --scheduler make a set processed in tiles: its signature is the sum of the
    tiles' (the same as one block), and the archive records the tiling and every file with its
    SHA-256 (no per-point datasets).
    """
    from ..jobs import signature as signature_job

    show(signature_job(sources, output, png=png_output, sg=sg_output, report=report, plots=plots,
                       points=not no_points, render=render, crs=crs, pipeline=pipeline, execution=execution,
                       overwrite=overwrite, resume=resume, columns=columns, aoi=aoi), quiet=quiet, as_json=as_json)
