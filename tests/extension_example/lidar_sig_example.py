"""lidar-sig-example: one extension of lidar_sig of each kind (docs/extending.md)."""
from __future__ import annotations

import os

import click
import numpy as np
from numpy.typing import NDArray

import lidar_sig as ls
from lidar_sig.io import atomic_output
from lidar_sig.io.fields import Fields
from lidar_sig.io.formats import POINTS, Format
from lidar_sig.metrics import Metric, Operand
from lidar_sig.plugins import Descriptor, NeighborhoodBatch, Strategy


class PlainCovariance(Descriptor):
    """The covariance tensor of each neighbourhood, every neighbour counting alike, in numpy."""

    name = "plain-covariance"
    summary = "covariance tensor, neighbours counted alike, in numpy (example)"

    def eigenvalues(self, batch: NeighborhoodBatch) -> NDArray[np.float64]:
        listed = np.arange(batch.idx.shape[1])[None, :] < batch.n[:, None]  # past n a row holds no neighbour
        points = batch.xyz[np.where(listed, batch.idx, 0)]  # (B, K, 3)
        out = np.full((*batch.counts.shape, 3), np.nan)  # (B, S, 3): NaN where a scale is undefined
        for s in range(batch.counts.shape[1]):
            n = batch.counts[:, s]  # neighbours within scale s, x_i included; 0 where too few
            rows = np.flatnonzero(n > 0)
            inside = (np.arange(points.shape[1])[None, :] < n[rows, None])[..., None]  # (R, K, 1)
            count = n[rows, None].astype(np.float64)  # (R, 1)
            mean = (points[rows] * inside).sum(axis=1) / count
            centred = (points[rows] - mean[:, None, :]) * inside
            out[rows, s] = np.linalg.eigvalsh(np.einsum("rki,rkj->rij", centred, centred) / count[:, :, None])
        return out


class LargestScale(Strategy):
    """The saliency of the largest scale: one neighbourhood per point, as the paper's single-scale runs."""

    name = "largest"
    summary = "saliency at the largest scale (example)"
    default_scales = ls.knn(20, 30, 40)

    def combine(self, per_scale: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.int64] | None]:
        return per_scale[:, -1, :], None  # chooses no scale per point: no OptimalScale output


def hellinger(a: Operand, b: Operand) -> float:
    """The Hellinger distance of two class distributions, in [0, 1]: 0 for the same shares."""
    p, q = a.totals / max(int(a.totals.sum()), 1), b.totals / max(int(b.totals.sum()), 1)
    return float(np.sqrt(0.5 * np.sum((np.sqrt(p) - np.sqrt(q)) ** 2)))


HELLINGER = Metric("hellinger", "d_Hellinger", "0 to 1", 0.0, True, "Hellinger distance of class distributions",
                   "changes in class shares, a rare class weighing more than in L1", of=hellinger, needs_labels=True)


def read_npz(path: str | os.PathLike[str]) -> ls.PointCloud:
    """A point cloud saved by :func:`write_npz`: columns x, y, z and, if there, classification."""
    with np.load(path) as columns:
        labels = columns["classification"] if "classification" in columns else None
        return ls.PointCloud(np.column_stack([columns["x"], columns["y"], columns["z"]]), labels, path=str(path))


def write_npz(path: str | os.PathLike[str], cloud: ls.PointCloud, fields: Fields, *, overwrite: bool = False) -> None:
    """The cloud's coordinates and labels, and each per-point output, as the columns of a .npz file,
    written whole or not at all (atomic_output)."""
    columns = {"x": cloud.xyz[:, 0], "y": cloud.xyz[:, 1], "z": cloud.xyz[:, 2], **fields}
    if cloud.labels is not None:
        columns["classification"] = cloud.labels
    with atomic_output(path, overwrite=overwrite) as temporary:
        np.savez(temporary, **columns)


NPZ = Format("NumPy", (".npz",), (POINTS,), reader=read_npz, writer=write_npz)


@click.command()
@click.argument("path")
def extent(path: str) -> None:
    """Print a point cloud's number of points and its extent."""
    cloud = ls.read(path)
    low, high = cloud.xyz.min(axis=0), cloud.xyz.max(axis=0)
    click.echo(f"{path}: {len(cloud):,} points")
    for axis, a, b in zip("xyz", low, high):
        click.echo(f"  {axis} from {a:.2f} to {b:.2f}")
