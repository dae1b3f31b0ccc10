"""`lidar-sig changes`: where two epochs differ, cell by cell (a registration-free change map)."""
import json

import click

from ..change_map import CELL, MIN_POINTS, changes, check_cell
from ..errors import LidarSigError
from ..metrics import METRIC_KEYS, METRIC_NAMES
from .group import cli
from .options import columns_option, overwrite_option, pipeline_options, render_option


@cli.command("changes")
@click.argument("a")
@click.argument("b")
@click.option("-o", "--output", default=None, metavar="FILE.tif",
              help="GeoTIFF with one band per metric (needs rasterio: pip install lidar-sig[geo]).")
@click.option("--cell", default=CELL, show_default=True, type=float, help="Cell side in metres.")
@click.option("--min-points", default=MIN_POINTS, show_default=True, type=int,
              help="Fewest points of a cell in each epoch for it to be compared; fewer gives no data.")
@click.option("--score", type=click.Choice(METRIC_KEYS), default=None,
              help="Metric that ranks the cells [default: kl, or emd_info for unlabelled clouds].")
@click.option("--top", default=10, show_default=True, type=click.IntRange(0, 100_000),
              help="Most changed cells to list.")
@click.option("--png", default=None, metavar="FILE.png", help="Also draw the map as a PNG picture.")
@click.option("--report", default=None, metavar="FILE.html",
              help="Write an HTML page with the map over both epochs and the top cells' signatures.")
@click.option("--json", "as_json", is_flag=True, help="Print one JSON object on stdout.")
@render_option
@overwrite_option
@columns_option
@pipeline_options
def changes_command(a, b, output, cell, min_points, score, top, png, report, as_json, render, overwrite, columns,
                    pipeline, method_given, quiet):
    """Map where A and B differ: per-cell signature metrics in a grid of the CRS.

    A and B are two epochs of the same area in one CRS: point-cloud files or folders of tiles.
    Each epoch's saliency is computed on the whole epoch; the points are then binned into cells
    aligned to multiples of the cell size, and the signatures of each cell compared.
    """
    cell_m = check_cell(cell)
    _check_outputs(output, png, report, overwrite)
    result = changes(a, b, cell=cell_m, pipeline=pipeline, min_points=min_points, score=score,
                     render=render or "smooth", columns=columns)
    written = _write(result, output, png, report, overwrite)
    if as_json:
        click.echo(json.dumps(result.to_dict(top)))
        return
    info = result.to_dict(top)
    grid = info["grid"]
    click.echo(f"{grid['rows']} x {grid['cols']} cells of {cell_m:g} m, {grid['valid']} compared (both epochs "
               f"with {min_points:,} points or more); ranked by {METRIC_NAMES[result.score]}")
    click.echo(f"{'rank':>4} {'x min':>10} {'y min':>11} {'points A':>9} {'points B':>9} {'score':>8}  classes A -> B")
    for item in info["top"]:
        classes = ", ".join(f"{k} {na:,}->{nb:,}" for k, (na, nb) in item["classes"].items())
        click.echo(f"{item['rank']:>4} {item['bounds'][0]:>10.1f} {item['bounds'][1]:>11.1f} {item['points_a']:>9,} "
                   f"{item['points_b']:>9,} {item['score']:>8.4f}  {classes}")
    if not quiet:
        for line in written:
            click.echo(line)


def _check_outputs(output, png, report, overwrite):
    """Refuse every output that cannot be written before anything is computed."""
    from ..io import check_outputs
    from ..io.geotiff import check_geotiff_output
    from ..reporting import check_report_path

    paths = [p for p in (output, png, report) if p]
    check_outputs(paths, overwrite=overwrite)
    if output:
        check_geotiff_output(output, overwrite=overwrite)
    if png and not png.lower().endswith(".png"):
        raise LidarSigError("the map is written as .png", path=png)
    if report:
        check_report_path(report, overwrite=overwrite)


def _write(result, output, png, report, overwrite):
    """Write the outputs together (all or none); lines saying what was written."""
    from ..io import output_group

    lines = []
    with output_group():
        for path in (output, png, report):
            if path:
                result.save(path, overwrite=overwrite)
                lines.append(f"wrote {path}")
    return lines
