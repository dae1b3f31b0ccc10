"""`lidar-sig catalog`: one signature per tile of a survey, in a catalogue made or grown."""
import click

from .options import aoi_option, crs_option, execution_options, json_option, overwrite_option, pipeline_options, resume_option
from .summaries import show


@click.command()
@click.argument("inputs", nargs=-1, required=True)
@click.option("-o", "--output", required=True, metavar="FILE.h5",
              help="The catalogue: made, or grown when it exists (tiles already in it, same path and SHA-256, "
                   "are not computed again).")
@overwrite_option
@crs_option
@execution_options(tiles=False)
@resume_option
@json_option
@aoi_option
@pipeline_options
def catalog(inputs, output, overwrite, crs, execution, resume, as_json, aoi, pipeline, method_given, quiet):
    """Compute the signature of every LAS/LAZ tile of INPUTS (files and folders) into a catalogue,
    for `lidar-sig similar` and `lidar-sig outliers`.

    Each tile's saliency is computed on the tile alone. An existing catalogue grows: new and
    changed files are computed, the others kept; it holds one method (method options that
    differ from its own are refused). --overwrite makes it anew.
    """
    from ..jobs import catalog as catalog_job

    show(catalog_job(inputs, output, crs=crs, pipeline=pipeline, execution=execution, resume=resume, overwrite=overwrite,
                     method_given=method_given, aoi=aoi), quiet=quiet, as_json=as_json)
