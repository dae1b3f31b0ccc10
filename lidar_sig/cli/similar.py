"""`lidar-sig similar`: the tiles of a catalogue nearest to a query, best first."""
import json

import click

from ..base.progress import settings as progress_settings
from .options import Choice, columns_option, metric_keys, overwrite_option
from .summaries import say


@click.command()
@click.argument("query")
@click.argument("catalogue")
@click.option("--top", default=10, show_default=True, type=click.IntRange(1), help="How many tiles to list.")
@click.option("--metric", type=Choice(lambda: ("distance",) + metric_keys()), default="distance", show_default=True,
              help="Rank by the combined distance (every metric over its spread) or by one metric.")
@click.option("--shortlist", type=click.IntRange(1), default=None,
              help="Tiles that get the full metrics after screening [default: max(4 x top, 20)].")
@click.option("-o", "--output", default=None, metavar="FILE.gpkg",
              help="GeoPackage of the tiles found: their footprints with rank, distance and every metric, in their "
                   "QGIS style.")
@overwrite_option
@click.option("--json", "as_json", is_flag=True, help="Print one JSON object on stdout.")
@columns_option
@click.option("-q", "--quiet", is_flag=True, help="No progress or notes.")
def similar(query, catalogue, top, metric, shortlist, output, overwrite, as_json, columns, quiet):
    """List the tiles of CATALOGUE most like QUERY, best first, with every metric's value.

    QUERY is a tile of the catalogue (its file name, stem or path), a point cloud (computed with
    the catalogue's method) or a signature archive made with that method.
    """
    from ..survey_catalog import Catalog
    from ..metrics import METRIC_KEYS, METRIC_NAMES

    if output:
        from ..io.atomic import check_output
        from ..io.formats import VECTOR, check_format

        check_format(output, VECTOR, said="the similar tiles (a GeoPackage)")
        check_output(output, overwrite=overwrite)
    with progress_settings(enabled=False if quiet else None):
        found = Catalog(catalogue).similar(query, top=top, metric=metric, shortlist=shortlist, columns=columns)
        if output:
            found.write_geopackage(output, overwrite=overwrite)
    if as_json:
        click.echo(json.dumps({**found.to_dict(), "written": [str(output)] if output else []}))
        return
    q, s = found.query, found.shortlist
    kind = {"tile": "a tile of the catalogue, left out of the list", "cloud": "a cloud, computed with the catalogue's method",
            "archive": "an archive made with the catalogue's method"}[q["kind"]]
    say(f"query {q['name']} ({kind}); ranked by {metric}; full metrics for {s['screened_by']}"
        + ("" if s["certain"] else " (the top may miss a tile outside the shortlist)"))
    keys = [k for k in METRIC_KEYS if k in found.results[0]] if found.results else []
    head = f"{'rank':>4}  {'distance':>8}  " + "  ".join(f"{METRIC_NAMES[k]:>10}" for k in keys) + "  tile"
    say(head)
    for r in found.results:
        say(f"{r['rank']:>4}  {r['distance']:>8.4f}  " + "  ".join(f"{r[k]:>10.4f}" for k in keys)
            + f"  {r['name']}")
    if output and not quiet:
        say(f"wrote {output}")
