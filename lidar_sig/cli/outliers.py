"""`lidar-sig outliers`: every tile of a catalogue scored by how unlike it is to its neighbours and
the survey, highest first; a GeoPackage of the footprints and an HTML report for review."""
import json

import click

from ..base.errors import counted, printable
from ..base.progress import settings as progress_settings
from .options import overwrite_option
from .summaries import say


@click.command()
@click.argument("catalogue")
@click.option("-o", "--output", default=None, metavar="FILE.gpkg",
              help="Write the tiles' footprints with every score and metric as a GeoPackage layer (QGIS, GDAL).")
@click.option("--report", default=None, metavar="FILE.html",
              help="Write the review page: map of scores, top outliers beside their neighbours, tiles by likeness.")
@click.option("--reach", type=click.FloatRange(0, min_open=True), default=None, metavar="METRES",
              help="Footprints within this distance are neighbours [default: a quarter of the median tile side].")
@click.option("--top", type=click.IntRange(1), default=10, show_default=True,
              help="Tiles listed (the JSON and the GeoPackage hold them all); outliers shown in the report: 3.")
@click.option("--json", "as_json", is_flag=True, help="Print one JSON object on stdout (every tile).")
@overwrite_option
@click.option("-q", "--quiet", is_flag=True, help="No progress or summaries.")
def outliers(catalogue, output, report, reach, top, as_json, overwrite, quiet):
    """Score every tile of CATALOGUE by how unlike it is to its spatial neighbours and to the
    survey as a whole, highest first, with the classes that make the difference.
    """
    from ..jobs import outliers as outliers_job

    with progress_settings(enabled=False if quiet else None):
        done = outliers_job(catalogue, output=output, report=report, reach=reach, overwrite=overwrite)
    found = done.found
    if as_json:
        click.echo(json.dumps(done.to_dict()))
        return
    if quiet:
        return
    say(f"{counted(len(found.results), 'tile')}, neighbours within {found.reach:.3g} m; "
        "score = mean robust z of the median screening distance to the neighbours and to the survey")
    for note in found.notes:
        click.echo(printable(f"lidar-sig: note: {note}"), err=True)
    say(f"{'rank':>4}  {'score':>6}  {'z neighb.':>9}  {'z survey':>8}  tile  (classes that make the difference)")
    for r in found.results[:top]:
        near = "-" if r["z_neighbours"] is None else f"{r['z_neighbours']:.2f}"
        classes = ", ".join(f"{c['class']} {c['difference']:+.1f} pts" for c in r["classes"])
        rank = f"{r['rank']}{'*' if r['outlier'] else ' '}"
        say(f"{rank:>5} {r['score']:>6.2f}  {near:>9}  {r['z_survey']:>8.2f}  {r['name']}"
            + (f"  ({classes})" if classes else ""))
    if len(found.results) > top:
        say(f"  ... {len(found.results) - top:,} more (--top, --json)")
    say(found.verdict(marked=", marked *"))
    for line in done.lines:
        say(line)
