"""`lidar-sig compare`: every metric between the signatures of two clouds."""
import json
from pathlib import Path

import click

from ..io import HDF5_EXTENSIONS, load_signature, read
from ..metrics import compare as compare_signatures
from . import cli
from .options import columns_option, pipeline_options
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
@columns_option
@pipeline_options
def compare(a, b, as_json, columns, pipeline, quiet):
    """Compare the signatures of A and B (point-cloud files or signature archives, in any mix)."""
    paths = [a, b]
    is_archive = [Path(p).suffix.lower() in HDF5_EXTENSIONS for p in paths]
    clouds = [None if arch else read(p, columns=columns) for p, arch in zip(paths, is_archive)]
    notes = []
    loaded = [c for c in clouds if c is not None]
    if len(loaded) == 2 and any(c.labels is None for c in loaded):
        for c in loaded:  # both unlabeled: one class each, so the signatures stay comparable
            c.labels = None
    sigs, meta, lines = [], [], []
    for path, cloud in zip(paths, clouds):
        if cloud is None:
            sig = load_signature(path)
            sigs.append(sig)
            meta.append(sig.metadata)
            lines.append(f"{path}: archive of {sig.n_points:,} points, {sig.metadata.get('descriptor', '?')} "
                         f"{sig.metadata.get('strategy', '?')}, {sig.metadata.get('scales', '?')}")
        else:
            result = pipeline.run(cloud)
            sigs.append(result.signature)
            meta.append(result.metadata)
            lines.append(run_summary(path, result))
    metrics = compare_signatures(sigs[0], sigs[1])
    if metrics["kl"] is None:
        notes.append("semantic metrics (kl, l1) need class labels in both clouds; comparing geometry only")
    scales = [m.get("resolved_scales") for m in meta]
    if (all(m.get("scale_kind") == "radius" and m.get("scale_units") == "normalized" for m in meta)
            and all(s is not None for s in scales)):
        ra, rb = scales[0][-1], scales[1][-1]
        if max(ra, rb) > (1 + RADII_TOLERANCE) * min(ra, rb):
            notes.append(f"normalized radii resolve to different metric radii ({ra:.4g} in A, "
                         f"{rb:.4g} in B: {abs(ra / rb - 1):.0%} apart) because the clouds differ in "
                         "extent; for the same neighbourhoods use --units metric --radii R1,R2,R3")
    for note in notes:
        click.echo(f"lidar-sig: warning: {note}", err=True)
    if as_json:
        out = dict(metrics)
        for key, path, m in zip("ab", paths, meta):
            out[key] = {"path": path, "points": int(m.get("n_points", 0)), "undefined": int(m.get("n_undefined", 0)),
                        "capped": int(m.get("n_capped", 0)), "scales": list(m.get("resolved_scales", [])),
                        "scale_kind": m.get("scale_kind"), "scale_units": m.get("scale_units") or "k"}
        out.update(descriptor=meta[0].get("descriptor"), strategy=meta[0].get("strategy"), warnings=notes)
        click.echo(json.dumps(out))
        return
    click.echo("A " + lines[0])
    click.echo("B " + lines[1])
    click.echo("")
    for key, name, what in METRICS:
        value = metrics[key]
        shown = "n/a" if value is None else f"{value:.4f}"
        click.echo(f"  {name:<11} {shown:>8}   {what}")
