"""Options shared by the commands: descriptor, strategy, scales, weights, classes, rendering.

The command line starts without the library's science (numpy and what it loads): a command
imports what it computes with when it runs, and the choices and defaults the options show that
the library defines (``WEIGHTS``, ``RENDERINGS``, ...) are read when first needed, through
:class:`Choice` and :class:`Default` (docs/architecture.md).
"""
from __future__ import annotations

import functools
import math

import click

from ..base.errors import LidarSigError
from ..base.progress import settings as progress_settings


class Choice(click.Choice):
    """A click.Choice among names the library defines, given as a function returning them: called
    when the choices are first needed (the command's help, a value to check), not when the
    command line starts."""

    def __init__(self, names, case_sensitive=True):  # not click.Choice's, which would store the choices
        self._names = names
        self.case_sensitive = case_sensitive

    @property
    def choices(self):
        return tuple(self._names())


class Default:
    """An option's default that the library defines, given as a function returning it: click calls
    it for the value, and the help shows its text (``show_default=True``; for a plain function
    click would show "(dynamic)")."""

    def __init__(self, value):
        self._value = value

    def __call__(self):
        return self._value()

    def __str__(self):
        return str(self._value())


def _weights():
    from ..numerics.neighbors import WEIGHTS

    return WEIGHTS


def metric_keys():
    """The keys of the metrics, in the order of every table (``lidar_sig.metrics.METRIC_KEYS``)."""
    from ..metrics import METRIC_KEYS

    return METRIC_KEYS


def renderings():
    """The renderings of the signatures, the default first (``lidar_sig.method.signature_raster.RENDERINGS``)."""
    from ..method.signature_raster import RENDERINGS

    return RENDERINGS


# Method options: None when not given, so that a command can tell what the user asked for (an
# archive compared with a cloud brings its own method).
METHOD_OPTIONS = ("descriptor", "strategy", "radii", "units", "k", "weights", "max_neighbors", "classes",
                  "keep_noise")


def number_list(text, option):
    """Comma-separated finite numbers of an option value; refuses empty lists, empty items
    ("1,,2") and non-finite numbers."""
    items = text.split(",")
    if not text.strip():
        raise LidarSigError(f"{option} needs at least one value, got {text!r}")
    if not all(v.strip() for v in items):
        raise LidarSigError(f"{option} has an empty item in {text!r}; separate the values by single commas "
                            "(e.g. 1,0.5)")
    try:
        values = [float(v) for v in items]
    except ValueError:
        raise LidarSigError(f"{option} must be comma-separated numbers, got {text!r}") from None
    if not all(math.isfinite(v) for v in values):
        raise LidarSigError(f"{option} must be finite numbers, got {text!r}")
    return values


def not_empty(what):
    """A click callback refusing an empty value, naming the option and what it takes (``what``:
    text, or a function giving it, called only then): an empty --descriptor used to mean the
    default, an empty --report no report."""
    def check(ctx, param, value):
        if value is not None and not value.strip():
            raise LidarSigError(f"{param.opts[0]} is empty; give {what() if callable(what) else what}")
        return value
    return check


def _registered(kind):
    def names():
        from ..plugins import available

        return "one of " + ", ".join(available(kind))
    return names


def pipeline_options(func):
    """Decorate a command with the method options; it receives ``pipeline`` (built from them)
    and ``method_given`` (the names of those the user gave)."""
    opts = [
        click.option("--descriptor", default=None, callback=not_empty(_registered("descriptor")),
                     help="Local geometric descriptor: c3dcm, t3dvt, t3dvt-get or a plugin (see "
                          "`lidar-sig plugins`) [default: c3dcm]."),
        click.option("--strategy", default=None, callback=not_empty(_registered("strategy")),
                     help="Scale strategy: multiscale or optimal [default: multiscale]."),
        click.option("--k", "k", default=None,
                     help="k-nearest scales, comma-separated [default: 20,30,40 for multiscale, "
                          "10,20,...,100 for optimal]."),
        click.option("--radii", default=None,
                     help="Spherical scales instead of --k, comma-separated, in metres (converted "
                          "to the file's unit from its CRS) or --units normalized."),
        click.option("--units", type=click.Choice(["metric", "normalized"]), default=None,
                     help="Units of --radii: metric (metres) or normalized (the paper's: half the "
                          "longest bounding-box side is 1; not rotation invariant) [default: metric]."),
        click.option("--weights", type=Choice(_weights), default=None,
                     help="Neighbours count by the area they stand for, or equally (the paper's) "
                          "[default: area]."),
        click.option("--max-neighbors", default=None, type=click.IntRange(3, 100_000),
                     help="Cap of a spherical neighbourhood, nearest first [default: 512]."),
        click.option("--classes", default=None,
                     callback=not_empty("one of asprs, paper, isprs-vaihingen or a .toml/.json file"),
                     help="Class table for the augmented signature: asprs, paper, isprs-vaihingen, "
                          "or a .toml/.json file (see docs/method.md) [default: asprs]."),
        click.option("--keep-noise", is_flag=True, default=None,
                     help="Use withheld points (LAS flag) and noise classes (ASPRS 7, 18) too; by default "
                          "they are left out of neighbourhoods, signatures and class shares, and undefined "
                          "in per-point outputs."),
        click.option("-q", "--quiet", is_flag=True, help="No progress bars or summaries."),
        click.option("-v", "--verbose", is_flag=True,
                     help="Print the parameters and timing of each step on stderr."),
    ]

    @functools.wraps(func)
    def wrapper(quiet, verbose, **kwargs):
        method = {name: kwargs.pop(name) for name in METHOD_OPTIONS}
        pipeline = make_pipeline(**method, quiet=quiet)
        given = {name for name, value in method.items() if value is not None}
        # progress bars on a terminal unless --quiet; step timings with --verbose
        with progress_settings(enabled=False if quiet else None, verbose=verbose):
            return func(pipeline=pipeline, method_given=given, quiet=quiet, **kwargs)

    for opt in reversed(opts):
        wrapper = opt(wrapper)
    return wrapper


def make_pipeline(descriptor=None, strategy=None, radii=None, units=None, k=None, weights=None,
                  max_neighbors=None, classes=None, keep_noise=None, quiet=False):
    """A Pipeline from command-line option values (None: the default)."""
    from ..pipeline.flow import Pipeline
    from ..method.scales import knn
    from ..method.scales import radii as make_radii

    if radii is not None and k is not None:
        raise LidarSigError("give either --radii or --k, not both")
    if units and radii is None:
        raise LidarSigError(f"--units {units} needs --radii in those units (e.g. --units {units} "
                            "--radii 1.0,1.1,1.2)")
    scales = None
    if radii is not None:
        scales = make_radii(*number_list(radii, "--radii"), units=units or "metric")
    elif k is not None:
        values = number_list(k, "--k")
        if any(v != int(v) or v < 2 for v in values):
            raise LidarSigError(f"--k must be whole numbers >= 2, got {k!r}")
        scales = knn(*[int(v) for v in values])
    extra = {} if max_neighbors is None else {"max_neighbors": max_neighbors}
    return Pipeline(descriptor or "c3dcm", strategy or "multiscale", scales, weights=weights or "area",
                    classes=classes or "asprs", progress=False if quiet else None,
                    keep_noise=bool(keep_noise), **extra)


overwrite_option = click.option("--overwrite", is_flag=True, help="Replace an existing output file.")

render_option = click.option(
    "--render", type=Choice(renderings), default=None,
    help="Rendering of Sg and Sas: smooth (a density estimate, robust to sampling), points (the "
         "paper's) or density (per-pixel shares) [default: smooth].")


def _columns(ctx, param, value):
    from ..io import parse_columns

    value = not_empty("the columns, e.g. x,y,z,-,label")(ctx, param, value)
    return parse_columns(value) if value is not None else None


columns_option = click.option(
    "--columns", default=None, callback=_columns,
    help="Columns of text point clouds, e.g. x,y,z,-,label ('-' skips one) [default: by count: "
         "3 xyz, 4 xyz+label, 7 ISPRS Vaihingen 3D; or the file's '# x y z ...' header].")


def report_options(func):
    """Decorate a command with ``--report FILE.html`` and ``--plots DIR``."""
    func = click.option("--plots", default=None, metavar="DIR", callback=not_empty("a folder"),
                        help="Also write every figure of the report as a PNG file in DIR.")(func)
    return click.option("--report", default=None, metavar="FILE.html", callback=not_empty("a file name"),
                        help="Write an HTML report with the figures (one self-contained file).")(func)


def execution_options(func=None, *, tiles=True, work_dir=True):
    """Decorate a command with the options of how it runs: ``--memory`` and, with ``tiles``,
    ``--tile-size``, ``--workers``, ``--scheduler``, with ``work_dir`` ``--work-dir``; it
    receives ``execution``, a :class:`lidar_sig.Execution` built from them (the library decides
    from it whether a file runs as one block or in tiles)."""
    if func is None:
        return functools.partial(execution_options, tiles=tiles, work_dir=work_dir)
    opts = []
    if tiles:
        opts += [click.option("--tile-size", type=click.FloatRange(0, min_open=True), default=None, metavar="METRES",
                              help="Side of the square processing tiles of a set, in metres [default: as many points "
                                   "as a process holds within --memory, from the files' density]."),
                 click.option("--memory", default=None, metavar="SIZE",
                              help="Memory budget of each process, e.g. 1GiB, 800MiB, 1.5G (B or a bare number is bytes): "
                                   "a LAS/LAZ file that needs more as one block is processed in tiles sized to it "
                                   "[default: 1GiB]."),
                 click.option("--workers", type=click.IntRange(min=1), default=None,
                              help="Local worker processes for tiles (a set, or one file processed in tiles because "
                                   "of --memory) [default: all cores; 1: this process alone]."),
                 click.option("--scheduler", default=None, metavar="ADDRESS", callback=not_empty("an address"),
                              help="Run the tiles on this dask.distributed scheduler (e.g. tcp://host:8786) instead "
                                   "of local processes; needs the dask extra.")]
    else:
        opts += [click.option("--workers", type=click.IntRange(min=1), default=None,
                              help="Local worker processes [default: all cores; 1: this process alone]."),
                 click.option("--scheduler", default=None, metavar="ADDRESS", callback=not_empty("an address"),
                              help="Run the tasks on this dask.distributed scheduler (e.g. tcp://host:8786) instead "
                                   "of local processes; needs the dask extra.")]
    if work_dir:
        opts.append(click.option("--work-dir", default=None, metavar="DIR", callback=not_empty("a folder"),
                                 help="Scratch folder of a run in tiles (staged points, finished tiles); every worker "
                                      "must see it at this path [default: beside or inside the output]."))

    @functools.wraps(func)
    def wrapper(**kwargs):
        from ..tiling.execution import Execution

        given = {k: kwargs.pop(k) for k in ("memory", "tile_size", "workers", "scheduler", "work_dir") if k in kwargs}
        if given.get("memory") is None:
            given.pop("memory", None)
        return func(execution=Execution(**given), **kwargs)

    for opt in reversed(opts):
        wrapper = opt(wrapper)
    return wrapper


resume_option = click.option("--resume", is_flag=True,
                             help="Reuse what an earlier run in tiles of the same files and method finished (kept "
                                  "in its work folder after a failure).")
json_option = click.option("--json", "as_json", is_flag=True, help="Print one JSON object on stdout.")
