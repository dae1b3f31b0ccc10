"""Options shared by the commands: descriptor, strategy, scales, classes, output."""
from __future__ import annotations

import functools

import click

from ..errors import LidarSigError
from ..pipeline import Pipeline
from ..scales import knn, radii


def _floats(text, what):
    try:
        return [float(v) for v in text.split(",") if v.strip()]
    except ValueError:
        raise LidarSigError(f"{what} must be comma-separated numbers, got {text!r}") from None


def pipeline_options(func):
    """Decorate a command with the method options; it receives ``pipeline`` instead."""
    opts = [
        click.option("--descriptor", default="c3dcm", show_default=True,
                     help="Local geometric descriptor (see `lidar-sig plugins`)."),
        click.option("--strategy", default="multiscale", show_default=True,
                     help="Scale strategy: multiscale or optimal."),
        click.option("--radii", default=None,
                     help="Spherical scales, comma-separated [default: 0.009,0.010,0.011 normalized "
                          "for multiscale]."),
        click.option("--units", type=click.Choice(["normalized", "metric"]), default=None,
                     help="Units of --radii: normalized (half the longest bounding-box side is 1, "
                          "the paper's choice) or metric (file units) [default: normalized]."),
        click.option("--k", "k", default=None,
                     help="k-nearest scales, comma-separated [default: 10,20,...,100 for optimal]."),
        click.option("--max-neighbors", default=512, show_default=True, type=click.IntRange(3),
                     help="Cap of a spherical neighbourhood (nearest first)."),
        click.option("--classes", default="asprs", show_default=True,
                     help="Class table for the augmented signature: asprs, paper, isprs-vaihingen, "
                          "or a .toml/.json file (see docs/method.md)."),
        click.option("-q", "--quiet", is_flag=True, help="No progress bars or summaries."),
    ]

    @functools.wraps(func)
    def wrapper(descriptor, strategy, radii, units, k, max_neighbors, classes, quiet, **kwargs):
        pipeline = make_pipeline(descriptor, strategy, radii, units, k, max_neighbors, classes, quiet)
        return func(pipeline=pipeline, quiet=quiet, **kwargs)

    for opt in reversed(opts):
        wrapper = opt(wrapper)
    return wrapper


def make_pipeline(descriptor, strategy, radii_text, units, k_text, max_neighbors, classes, quiet):
    """A Pipeline from command-line option values."""
    if radii_text and k_text:
        raise LidarSigError("give either --radii or --k, not both")
    if units and not radii_text:
        raise LidarSigError(f"--units {units} needs --radii in those units (e.g. --units metric "
                            "--radii 0.5,0.75,1.0)")
    scales = None
    if radii_text:
        scales = radii(*_floats(radii_text, "--radii"), units=units or "normalized")
    elif k_text:
        values = _floats(k_text, "--k")
        if any(v != int(v) for v in values):
            raise LidarSigError(f"--k must be whole numbers, got {k_text!r}")
        scales = knn(*[int(v) for v in values])
    return Pipeline(descriptor, strategy, scales, max_neighbors=max_neighbors, classes=classes,
                    progress=False if quiet else None)


overwrite_option = click.option("--overwrite", is_flag=True, help="Replace an existing output file.")


def _columns(ctx, param, value):
    from ..io import parse_columns

    return parse_columns(value) if value else None


columns_option = click.option(
    "--columns", default=None, callback=_columns,
    help="Columns of text point clouds, e.g. x,y,z,-,label ('-' skips one) [default: by count: "
         "3 xyz, 4 xyz+label, 7 ISPRS Vaihingen 3D; or the file's '# x y z ...' header].")
