"""`lidar-sig saliency`: per-point saliency written as LAS/LAZ extra dimensions (and other formats)."""
import click

from .options import aoi_option, crs_option, columns_option, execution_options, json_option, overwrite_option, pipeline_options, resume_option
from .summaries import show


@click.command()
@click.argument("sources", nargs=-1, required=True)
@click.option("-o", "--output", required=True,
              help="Output point cloud: LAS/LAZ (extra dimensions), PLY/PCD (attributes) or text (columns); "
                   "for a set of tiles, a folder that gets one LAS/LAZ per input file.")
@overwrite_option
@columns_option
@crs_option
@execution_options
@resume_option
@json_option
@aoi_option
@pipeline_options
def saliency(sources, output, overwrite, columns, crs, execution, resume, as_json, aoi, pipeline, method_given, quiet):
    """Write SOURCES with per-point Cl, Cs, Cp, Egeom, GeomClass (and OptimalScale).

    One file is processed as one block, or in tiles with halos when one block would need more
    memory than --memory (the same results; OUTPUT is then LAS/LAZ). Several files, folders of
    LAS/LAZ tiles, or any of --tile-size, --workers, --scheduler make a set processed in tiles
    (the same results as one block); OUTPUT is then a folder, or for one input file a LAS/LAZ
    file.
    """
    from ..jobs import saliency as saliency_job

    show(saliency_job(sources, output, crs=crs, pipeline=pipeline, execution=execution, overwrite=overwrite, resume=resume, aoi=aoi,
                      columns=columns), quiet=quiet, as_json=as_json)
