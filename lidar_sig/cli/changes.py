"""`lidar-sig changes`: where epochs differ, cell by cell (a registration-free change map with a
level of detection per cell)."""
import json

import click

from ..base.errors import LidarSigError, counted
from .group import cli
from .options import (aoi_option, crs_option, Choice, Default, columns_option, execution_options, metric_keys, overwrite_option, pipeline_options,
                      render_option, resume_option)
from .summaries import say


def _confidence():
    from ..change_map import CONFIDENCE

    return CONFIDENCE


@cli.command("changes")
@click.argument("epochs", nargs=-1, required=True, metavar="A B [C ...]")
@click.option("-o", "--output", default=None, metavar="FILE.tif",
              help="Cloud-Optimized GeoTIFF: the score, its level of detection, significant (0/1) and every metric "
                   "per cell, with its QGIS style beside it (FILE.qml) (needs rasterio: pip install lidar-sig[geo]).")
@click.option("--cells", default=None, metavar="FILE.gpkg",
              help="GeoPackage of the cells either epoch covers: coverage, score, level of detection, significance, "
                   "the classes that changed most; with a spatial index and its QGIS style.")
@click.option("--points", default=None, metavar="FILE.laz",
              help="The later epoch's points with their saliency and their cell's change (ChangeScore, ChangeLoD, "
                   "ChangeSignificant), in any point-cloud format (two epochs).")
@click.option("--cell", default="auto", show_default=True, metavar="METRES|auto",
              help="Cell side in metres, or auto: chosen from the epochs' densities.")
@click.option("--min-points", default="auto", show_default=True, metavar="N|auto",
              help="Fewest points with defined saliency of a cell in each epoch for it to be compared, or auto: "
                   "a fifth of a full cell.")
@click.option("--sample-density", "sample_density", default="auto", show_default=True, metavar="POINTS_PER_M2|auto|all",
              help="Points per m² of an epoch its cells take at most: a denser epoch's cells take a sample of its "
                   "points, whose saliency alone is computed (neighbours among all); auto: 5, more for cells under "
                   "25 m (3,125 points a cell); all: every point.")
@click.option("--score", type=Choice(metric_keys), default=None,
              help="Metric that ranks the cells [default: kl, or fv for unlabelled epochs or class schemes that "
                   "barely overlap].")
@click.option("--confidence", default=Default(_confidence), show_default=True, type=click.FloatRange(0.5, 0.9999),
              help="Confidence of the level of detection (one-sided).")
@click.option("--class-map", "class_map", multiple=True, metavar="CODES=NAME",
              help="Merge class codes of either epoch into one class before comparing, e.g. "
                   "1,3,4,5=vegetation-or-other (repeatable, or ';'-separated), or a .toml/.json file.")
@click.option("--top", default=10, show_default=True, type=click.IntRange(0, 100_000),
              help="Most changed cells to list (100000 lists every compared cell).")
@click.option("--png", default=None, metavar="FILE.png", help="Also draw the map as a PNG picture.")
@click.option("--report", default=None, metavar="FILE.html",
              help="Write an HTML page with the map over both epochs and the top cells' signatures.")
@click.option("--json", "as_json", is_flag=True, help="Print one JSON object on stdout.")
@render_option
@overwrite_option
@columns_option
@crs_option
@execution_options
@resume_option
@aoi_option
@pipeline_options
def changes_command(epochs, output, cells, points, cell, min_points, sample_density, score, confidence, class_map, top,
                    png, report, as_json, render, overwrite, columns, crs, execution, resume, aoi, pipeline, method_given,
                    quiet):
    """Map where epochs differ: per-cell signature metrics in a grid of the CRS, each with its
    level of detection, so that the cells that changed significantly stand out.

    A B [C ...] are epochs of the same area in one CRS, in time order: point-cloud files or
    folders of tiles. Each epoch's saliency is computed once on the whole epoch; the points are
    then binned into cells aligned to multiples of the cell size, and the signatures of each
    cell compared between consecutive epochs. Two epochs of LAS/LAZ files (a file, a folder, a
    glob pattern or a .vpc each, tiles cut on any grid) that one block would hold above --memory,
    or with --tile-size, --workers or --scheduler, are mapped in work units: the same map, in
    bounded memory, resumable (--resume).
    """
    cell = _auto_or(cell, "the cell size (--cell)", _metres)
    min_points = _auto_or(min_points, "the fewest points (--min-points)", _whole)
    sample_density = _sample_density(sample_density)
    from ..change_map import ChangeSeries
    from ..jobs import changes as changes_job

    done = changes_job(epochs, crs=crs, output=output, cells=cells, points=points, png=png, report=report, overwrite=overwrite,
                       top=top, cell=cell, pipeline=pipeline, min_points=min_points, score=score,
                       render=render or "smooth", columns=columns, confidence=confidence,
                       class_map=list(class_map) or None, execution=execution, resume=resume, aoi=aoi,
                       sample_density=sample_density)
    result, written = done.changes, done.lines
    if as_json:
        click.echo(json.dumps(done.to_dict()))
        return
    maps = result.maps if isinstance(result, ChangeSeries) else [result]
    first = maps[0]
    say(f"{first.grid.rows} x {first.grid.cols} cells of {first.cell:g} m ({_rule(first.cell_rule)}), "
        f"compared where both epochs hold {counted(first.min_points, 'point')} with defined saliency "
        f"({_rule(first.min_points_rule)}); densities "
        + ", ".join(f"{d:.3g}" for d in _densities(result)) + " points/m²" + _sampled(maps))
    for k, cm in enumerate(maps):
        where = f"{result.interval_name(k)}: " if len(maps) > 1 else ""
        for line in _header(cm):
            say(where + line)
        say(f"{'rank':>5} {'x min':>10} {'y min':>11} {'points A':>9} {'points B':>9} {'score':>8} "
            f"{'lod':>8} {'dH (m)':>7} {'lod':>6} {'z':>5}  classes A -> B")
        for item in cm.top(top):
            classes = ", ".join(f"{k} {na:,}->{nb:,}" for k, (na, nb) in item["classes"].items())
            lod = "" if item["lod"] is None else f"{item['lod']:.4f}"
            height_lod = "" if item["height_lod"] is None else f"{item['height_lod']:.2f}"
            z = "" if item["z"] is None else f"{item['z']:.1f}"
            mark = "*" if item["significant"] else " "
            say(f"{item['rank']:>4}{mark} {item['bounds'][0]:>10.1f} {item['bounds'][1]:>11.1f} "
                f"{item['points_a']:>9,} {item['points_b']:>9,} {item['score']:>8.4f} {lod:>8} "
                f"{item['height']:>7.2f} {height_lod:>6} {z:>5}  {classes}")
    if len(maps) > 1:
        counts = result.to_dict(0)["when"]["cells"]
        say("when: " + ", ".join(f"{counts[str(k)]} cells changed most in interval {k}"
                                 for k in range(1, len(maps) + 1))
            + f"; {counts['0']} compared, never significantly")
    if not quiet:
        for line in written:
            say(line)


def _header(cm):
    """The lines above a map's table: its cells by coverage state, then what is significant
    and how the rows are ordered, as :meth:`ChangeMap.ranked` orders them."""
    counts = cm.coverage()
    score = cm.score_name
    height = cm.names[cm.tests[1]]
    return [f"coverage: {counts['compared']} cells compared, {counts['appeared']} appeared (only B covers them), "
            f"{counts['vanished']} vanished (only A), {counts['too few points']} too few points, "
            f"{counts['not covered']} not covered",
            f"{cm.n_significant} changed significantly ({score} or {height} above its level of detection, "
            f"{cm.confidence:.0%} together), marked *; rows: significant first, then by how far above its level "
            "(lod_ratio, the map's colour)", *cm.answer()]


def _densities(result):
    from ..change_map import ChangeSeries

    if isinstance(result, ChangeSeries):
        return [m.density[0] for m in result.maps] + [result.maps[-1].density[1]]
    return list(result.density)


def _sampled(maps):
    """What the first line adds when the cells take a sample of a denser epoch's points."""
    said = next((text for text in (m.sample_text() for m in maps) if text), "")
    return f" ({said})" if said else ""


def _rule(rule):
    from ..change_map import AUTO

    return "auto" if rule == AUTO else "given"


def _metres(text, what):
    try:
        value = float(text)
    except ValueError:
        raise LidarSigError(f"{what} must be auto or a positive number of metres, got {text!r}") from None
    from ..change_map import check_cell

    return check_cell(value)


def _whole(text, what):
    try:
        value = int(text)
    except ValueError:
        raise LidarSigError(f"{what} must be auto or a whole number >= 1, got {text!r}") from None
    if value < 1:
        raise LidarSigError(f"{what} must be auto or a whole number >= 1, got {text!r}")
    return value


def _sample_density(text):
    """``--sample-density``: points per m² (a positive number), auto, or None for ``all``."""
    if text.strip().lower() == "all":
        return None
    if text.strip().lower() == "auto":
        from ..change_map import AUTO

        return AUTO
    try:
        value = float(text)
    except ValueError:
        value = float("nan")
    if not 0 < value < float("inf"):
        raise LidarSigError(f"--sample-density must be auto, all or a positive number of points per m² (e.g. 5), "
                            f"got {text!r}")
    return value


def _auto_or(text, what, parse):
    if text.strip().lower() == "auto":
        from ..change_map import AUTO

        return AUTO
    return parse(text, what)
