"""The epochs of a change map: each read from a file, a folder of tiles, a list of files, a glob
pattern of tiles or a virtual point cloud file (``.vpc``, as QGIS and PDAL write them; tiles
joined into one cloud), checked to be in one CRS, and each held with its saliency (an
:class:`Epoch`, which a caller may also compute once and give to several change maps)."""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..method.cloud import PointCloud
from ..method.crs import crs_name, same_crs
from ..base.errors import LidarSigError, a_kind, as_path
from ..io.tile_lists import check_distinct, tile_list


@dataclass
class Epoch:
    """One epoch of a change map: its name, cloud, per-point saliency (docs/method.md, "Saliency map"), the run's
    statistics (with the method that computed it), the points the run used (``kept``,
    :meth:`Pipeline.kept`; None for all) and, when known already, each point's key
    (:func:`~lidar_sig.change_map._cells.point_keys`, which chose the cells' sample)."""

    name: str
    cloud: object
    saliency: object
    metadata: dict = field(default_factory=dict)
    kept: np.ndarray = None
    keys: np.ndarray = None

    def used(self, values):
        """The rows of per-point ``values`` (coordinates, saliency) of the points the run used."""
        return values if self.kept is None else values[self.kept]

    @property
    def n_points(self):
        """The epoch's points, withheld and noise ones included."""
        return len(self.cloud)

    def cell_signature(self, flat, grid, classes, labelled, frame):
        """The signature of cell ``flat`` of ``grid`` (:func:`~lidar_sig.change_map._cells.cell_signature`)."""
        from ._cells import cell_signature, epoch_cells

        return cell_signature(self, np.flatnonzero(epoch_cells(self, grid) == flat), classes, labelled, frame)

    def view(self):
        """(coordinates (N, 3), saliency (N, 3)) of the points the run used: a report's top view."""
        return self.used(self.cloud.xyz), self.used(self.saliency.values)

    def write_points(self, path, extra, *, overwrite=False):
        """Write the epoch's points with their saliency and the fields ``extra(xy)`` of their
        (N, 2) coordinates (a change map's per-point change) to the point cloud ``path``."""
        from ..io import write_cloud

        write_cloud(path, self.cloud, self.saliency, scale_kind=self.metadata.get("scale_kind"),
                    scale_values=self.metadata.get("scale_values"), overwrite=overwrite,
                    extra=extra(self.cloud.xyz[:, :2]))


def compute_epoch(source, pipeline=None, *, columns=None):
    """The :class:`Epoch` of ``source`` (as :func:`read_epoch` takes it): read, and its saliency
    computed with ``pipeline`` (default ``Pipeline()``). Give it to
    :func:`~lidar_sig.change_map.changes` in place of the source to compute an epoch's saliency
    once for several change maps."""
    from ..pipeline.flow import pipeline_or_default

    pipeline = pipeline_or_default(pipeline)
    cloud = read_epoch(source, columns=columns)
    sal, stats = pipeline.saliency(cloud)
    return Epoch(cloud.path or "(in memory)", cloud, sal, stats, kept=pipeline.kept(cloud))


def read_epoch(source, *, columns=None):
    """A PointCloud from a file, a folder of tiles, a list of files, a glob pattern of tiles, a
    virtual point cloud file (``.vpc``), or a PointCloud.

    Tiles of one epoch are joined into one cloud (their saliency is then computed across tile
    edges); they must share one CRS and be all labelled or all unlabelled.
    """
    from ..io import CLOUD_EXTENSIONS, read

    if isinstance(source, PointCloud):
        return source
    if isinstance(source, Epoch):
        return source.cloud
    if isinstance(source, (str, Path)):
        as_path(source, "an epoch")  # a name the system cannot take is named first
    listed = tile_list(source) if isinstance(source, (str, Path)) else None
    if listed is not None:
        paths = listed
    elif isinstance(source, (str, Path)) and Path(source).is_dir():
        # regular files only, as a set of tiles takes them (a FIFO named *.laz would be waited on)
        paths = sorted(p for p in Path(source).iterdir() if p.suffix.lower() in CLOUD_EXTENSIONS and p.is_file())
        if not paths:
            raise LidarSigError(f"holds no point-cloud files ({', '.join(CLOUD_EXTENSIONS)})", path=source)
    elif isinstance(source, (list, tuple)):
        paths = list(source)
        if not paths:
            raise LidarSigError("an epoch given as a list needs at least one file")
    elif isinstance(source, (str, Path)):
        return read(source, columns=columns)
    else:
        raise LidarSigError(f"cannot read an epoch from {a_kind(source)}; give a file, a folder of "
                            "tiles, a list of files or a PointCloud")
    check_distinct([Path(p) for p in paths if isinstance(p, (str, Path))])  # a tile twice would count twice
    clouds = [read(p, columns=columns) for p in paths]
    if len(clouds) == 1:
        return clouds[0]
    first = clouds[0]
    for c in clouds[1:]:
        if not same_crs(first.crs, c.crs):
            raise LidarSigError(f"is in another CRS than {first.path}; tiles of one epoch must share one CRS",
                                path=c.path)
        if (c.labels is None) != (first.labels is None):
            raise LidarSigError(f"has {'no ' if c.labels is None else ''}class labels unlike {first.path}; "
                                "give tiles of one epoch that are all labelled or all unlabelled", path=c.path)
    labels = None if first.labels is None else np.concatenate([c.labels for c in clouds])
    withheld = None
    if any(c.withheld is not None for c in clouds):
        withheld = np.concatenate([c.withheld if c.withheld is not None else np.zeros(len(c), bool) for c in clouds])
    name = epoch_name(source, paths)
    return PointCloud(np.vstack([c.xyz for c in clouds]), labels, path=name, crs=first.crs, units=first.units,
                      withheld=withheld)


def epoch_name(source, paths):
    """The name of an epoch read from ``source`` as its files ``paths``: the file itself when
    there is one, the folder, pattern or .vpc as given, a list by its first file and count."""
    if len(paths) == 1:
        return str(paths[0])
    return str(source) if not isinstance(source, (list, tuple)) else f"{paths[0]} (+{len(paths) - 1} tiles)"


def check_same_crs(clouds, names):
    """Refuse two epochs that are not in one CRS (or of which one has none), naming both."""
    if (clouds[0].crs is None) != (clouds[1].crs is None):
        k = 0 if clouds[1].crs is None else 1  # the epoch that has one
        raise LidarSigError(f"{names[1 - k]} has no CRS while {names[k]} is in {crs_name(clouds[k].crs)}; "
                            "give both epochs in one CRS")
    if not same_crs(clouds[0].crs, clouds[1].crs):
        raise LidarSigError(f"{names[0]} and {names[1]} are in different CRS ({crs_name(clouds[0].crs)} / "
                            f"{crs_name(clouds[1].crs)}); reproject one epoch into the other's CRS first")
