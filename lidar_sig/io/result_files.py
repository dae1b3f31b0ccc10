"""Writing a pipeline Result by the path's extension: the cloud with its per-point saliency, the
signature archive, or the image of Sas."""
from __future__ import annotations

from pathlib import Path

from ..base.errors import LidarSigError, as_path
from ..base.progress import step


def write_result(result, path, *, overwrite=False, points=True, render="smooth"):
    """Write ``result`` (a :class:`lidar_sig.pipeline.flow.Result`) to ``path`` by extension: a point
    cloud with per-point saliency (.las/.laz extra dimensions, .ply/.pcd attributes,
    .xyz/.txt/.pts/.csv columns), a signature archive (.h5/.hdf5, with per-point datasets unless
    ``points=False``) or an image of Sas (.png); images are rendered as ``render``."""
    from . import write_archive, write_cloud
    from .formats import IMAGE, POINTS, SIGNATURE, format_of
    from .png import write_signature_png

    path = as_path(path, "write")
    if not isinstance(overwrite, bool):
        raise LidarSigError(f"overwrite must be True or False, got {overwrite!r}")
    fmt = format_of(path)
    holds = set(fmt.holds) if fmt is not None else set()
    with step(f"writing {path.name}", points=len(result.cloud)):
        if POINTS in holds:
            write_cloud(path, result.cloud, result.saliency, scale_kind=result.metadata["scale_kind"],
                        scale_values=result.metadata["scale_values"], overwrite=overwrite)
        elif SIGNATURE in holds:
            cloud = result.cloud
            sources = [cloud.path] if cloud.path and Path(cloud.path).is_file() else []
            write_archive(path, result.signature, saliency=result.saliency if points else None,
                          labels=cloud.labels if points else None, sources=sources,
                          render=render, overwrite=overwrite)
        elif IMAGE in holds:
            write_signature_png(path, result.signature, mode=render, overwrite=overwrite)
        else:
            raise LidarSigError(f"cannot write {path.suffix.lower() or 'files without extension'}; use a "
                                "point-cloud format, .h5 or .png", path=path)
