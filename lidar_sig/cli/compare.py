"""`lidar-sig compare`: every metric between the signatures of two clouds."""
import json

import click

from ..io import read
from ..metrics import compare as compare_signatures
from . import cli
from .options import pipeline_options
from .report import run_summary

# (key, paper name, what it says)
METRICS = (
    ("bhattacharyya", "d_BD-Img", "Bhattacharyya distance of Sas colour histograms, 0 = same"),
    ("ssim", "s_SSIM", "structural similarity of Sg images, 1 = same"),
    ("emd_info", "d_EMD-Info", "EMD of Egeom histograms (nats), 0 = same"),
    ("emd_img", "d_EMD-Img", "EMD of Sas colour histograms (RGB in [0, 1]), 0 = same"),
    ("fv", "delta_FV", "distance of Fisher vectors of saliency positions, 0 = same"),
    ("kl", "delta_KL", "symmetric KL divergence of class distributions, 0 = same"),
    ("l1", "L1", "L1 distance of class distributions, 0 = same"),
)
# Normalized radii resolve against each cloud's extent; warn when they differ by more than this.
RADII_TOLERANCE = 0.10


@cli.command()
@click.argument("a")
@click.argument("b")
@click.option("--json", "as_json", is_flag=True, help="Print one JSON object on stdout.")
@pipeline_options
def compare(a, b, as_json, pipeline, quiet):
    """Compare the signatures of point clouds A and B."""
    clouds = [read(a), read(b)]
    notes = []
    if any(c.labels is None for c in clouds):
        for c in clouds:
            c.labels = None
        notes.append("semantic metrics (kl, l1) need class labels in both clouds; "
                     "comparing geometry only")
    results = [pipeline.run(c) for c in clouds]
    metrics = compare_signatures(results[0].signature, results[1].signature)
    meta = [r.metadata for r in results]
    if meta[0]["scale_kind"] == "radius" and meta[0]["scale_units"] == "normalized":
        ra, rb = meta[0]["resolved_scales"][-1], meta[1]["resolved_scales"][-1]
        if max(ra, rb) > (1 + RADII_TOLERANCE) * min(ra, rb):
            notes.append(f"normalized radii resolve to different metric radii ({ra:.4g} in A, "
                         f"{rb:.4g} in B: {abs(ra / rb - 1):.0%} apart) because the clouds differ in "
                         "extent; for the same neighbourhoods use --units metric --radii R1,R2,R3")
    for note in notes:
        click.echo(f"lidar-sig: warning: {note}", err=True)
    if as_json:
        out = dict(metrics)
        for key, path, m in zip("ab", (a, b), meta):
            out[key] = {"path": path, "points": m["n_points"], "undefined": m["n_undefined"],
                        "capped": m["n_capped"], "scales": m["resolved_scales"],
                        "scale_kind": m["scale_kind"], "scale_units": m["scale_units"] or "k"}
        out.update(descriptor=meta[0]["descriptor"], strategy=meta[0]["strategy"], warnings=notes)
        click.echo(json.dumps(out))
        return
    click.echo("A " + run_summary(a, results[0]))
    click.echo("B " + run_summary(b, results[1]))
    click.echo("")
    for key, name, what in METRICS:
        value = metrics[key]
        shown = "n/a" if value is None else f"{value:.4f}"
        click.echo(f"  {name:<11} {shown:>8}   {what}")
