"""The result of a pipeline run on one cloud (:class:`Result`): per-point saliency, the signature
and the run's metadata, written to any format by extension (docs/method.md, "Outputs").

A cloud run as one block holds its values in memory. A LAS/LAZ file that one block would hold
above the memory budget is run in tiles and gives a result whose per-point values stay on disk,
in tiles, until asked for (:class:`TiledResult`): both answer the same calls, so that
``ls.Pipeline().run(path).write(out)`` is one line whatever the file's size.
"""
from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any, Self

from ..base.errors import LidarSigError, counted

if TYPE_CHECKING:
    from ..method.cloud import PointCloud
    from ..method.saliency_map import Saliency
    from ..method.signature_raster import Signature
    from ..tiling import KeptTiles


class Result:
    """Per-point saliency and the signature of one cloud, with the run's metadata.

    ``signature`` may be given, or made when first asked for by ``make_signature`` (a callable
    of no argument that pickles: :meth:`Pipeline.run` passes one, so that writing the points,
    which does not need a signature, saves making one: docs/performance.md).
    """

    #: False: the values are in memory (see :class:`TiledResult`).
    tiled = False

    def __init__(self, cloud: PointCloud, saliency: Saliency, signature: Signature | None = None,
                 metadata: dict[str, Any] | None = None, *,
                 make_signature: Callable[[], Signature] | None = None) -> None:
        if signature is None and make_signature is None:
            raise LidarSigError("a Result needs its signature or make_signature")
        self.cloud = cloud
        self.saliency = saliency
        self.metadata = {} if metadata is None else metadata
        self._signature = signature
        self._make_signature = make_signature

    @property
    def signature(self) -> Signature:
        """The cloud's Signature (Sg and Sas with the Egeom histogram; docs/method.md, "Signatures")."""
        if self._signature is None:
            assert self._make_signature is not None
            self._signature = self._make_signature()
            self._make_signature = None
        return self._signature

    def __repr__(self) -> str:
        m = self.metadata
        undefined = m.get("n_undefined")
        return (f"<Result {counted(int(m.get('n_points', 0)), 'point')}, {m.get('descriptor', '?')} "
                f"{m.get('strategy', '?')}, {m.get('scales', '?')}"
                + (f", {undefined:,} undefined" if undefined is not None else "")
                + (", in tiles" if self.tiled else "") + (f", from {m['source']}" if m.get("source") else "") + ">")

    def summary(self, name: str | None = None) -> str:
        """One line for people: points, method, scales, weights, units, undefined, capped,
        duplicate and left-out counts (what ``lidar-sig saliency`` prints), under ``name`` (by
        default the source's)."""
        from ..reporting.sections import scales_text

        m = self.metadata
        text = (f"{name or m.get('source') or '(in memory)'}: {counted(m['n_points'], 'point')}, {m['descriptor']} "
                f"{m['strategy']}, {scales_text(m)}, {m['weights']} weights, units {m['units']}; "
                f"{m['n_undefined']:,} undefined")
        if m["n_undefined"]:
            text += " (left out of the signature)"
        if m["n_capped"]:
            text += f", {counted(m['n_capped'], 'neighbourhood')} capped at {m['max_neighbors']}"
        if m["n_duplicates"]:
            text += f", {counted(m['n_duplicates'], 'duplicate point')} (one location each)"
        if m.get("n_excluded"):
            text += f", {counted(m['n_excluded'], 'withheld or noise point')} left out"
        return text

    def to_dict(self) -> dict[str, Any]:
        """The run's facts as plain JSON-able values (what ``--json`` prints for a cloud)."""
        keys = ("source", "n_points", "n_undefined", "n_capped", "n_duplicates", "n_excluded", "descriptor",
                "descriptor_params", "strategy", "scale_kind", "scale_values", "scale_units", "resolved_scales",
                "weights", "max_neighbors", "min_neighbors", "keep_noise", "units", "crs")
        out = {k: self.metadata[k] for k in keys if k in self.metadata}
        out["tiled"] = self.tiled
        return out

    def write(self, path: str | Path, *, overwrite: bool = False, points: bool | None = None,
              render: str = "smooth") -> None:
        """Write to ``path`` by extension: a point cloud with per-point saliency (.las/.laz extra
        dimensions, .ply/.pcd attributes, .xyz/.txt/.pts/.csv columns), a signature archive
        (.h5/.hdf5, with per-point datasets unless ``points=False``) or an image of Sas (.png);
        images are rendered as ``render`` (:func:`lidar_sig.io.result_files.write_result`)."""
        from ..io.result_files import write_result

        write_result(self, path, overwrite=overwrite, points=True if points is None else points, render=render)

    def to_open3d(self, *, colors: str = "saliency") -> Any:
        """An ``open3d.t.geometry.PointCloud`` with the per-point outputs as attributes and, by
        default, colours (R, G, B) = (Cl, Cs, Cp), undefined points grey; see
        :func:`lidar_sig.io.open3d.to_open3d`. ``o3d.visualization.draw(result.to_open3d())``
        shows the saliency."""
        from ..io.open3d import to_open3d

        return to_open3d(self, colors=colors)

    def close(self) -> None:
        """Free what the result keeps outside memory (nothing here; a result in tiles removes
        its work folder)."""

    def __enter__(self) -> Self:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


class TiledResult(Result):
    """The :class:`Result` of one LAS/LAZ file that one block would hold above the memory budget
    (or whose tiles were asked for), run in tiles with halos (the same values as one block): its
    per-point values stay in the run's work folder, in tiles, until they are asked for
    (``saliency`` and ``cloud`` read them all into memory); ``write`` streams them into a
    LAS/LAZ file chunk by chunk and refuses other point formats, which would hold them all. The
    work folder (:class:`lidar_sig.tiling.KeptTiles`) is removed by :meth:`close`, by leaving a
    ``with`` block, or when the result is collected.
    """

    tiled = True

    def __init__(self, kept: KeptTiles) -> None:  # not Result's: the values are in the tiles
        self.kept = kept
        self.metadata = kept.metadata
        self._cloud: PointCloud | None = None
        self._tiled_saliency: Saliency | None = None

    @property
    def work(self) -> Path:
        """The work folder that holds the per-point values, in tiles, until :meth:`close`."""
        return self.kept.work

    @property  # type: ignore[override]  # read from the tiles, not set
    def signature(self) -> Signature:
        """The file's Signature: the sum of its tiles' (count rasters are additive)."""
        return self.kept.signature

    @property  # type: ignore[override]
    def cloud(self) -> PointCloud:
        """The file read into a PointCloud (every point in memory: read when first asked for)."""
        if self._cloud is None:
            from ..io import read

            self._cloud = read(self.kept.source.path)
        return self._cloud

    @property  # type: ignore[override]
    def saliency(self) -> Saliency:
        """Per-point Saliency of the whole file, in its point order (gathered from the tiles
        into memory when first asked for, then kept)."""
        if self._tiled_saliency is None:
            self._tiled_saliency = self.kept.saliency()
        return self._tiled_saliency

    def summary_lines(self) -> list[str]:
        """What the tiles were (:meth:`lidar_sig.SetRun.summary`)."""
        return self.kept.summary_lines()

    def write(self, path: str | Path, *, overwrite: bool = False, points: bool | None = None,
              render: str = "smooth") -> None:
        """As :meth:`Result.write`, without holding the points: a LAS/LAZ file is streamed from
        the tiles, an archive (.h5) holds the signature and the tiling without per-point
        datasets (``points=True`` is refused: they would not fit the budget), a .png is Sas.
        Other point-cloud formats are refused: they are written whole."""
        from ..base.errors import arg, as_path
        from ..io import check_output, write_archive
        from ..io.formats import IMAGE, POINTS, SIGNATURE, format_of
        from ..io.png import write_signature_png
        from ..tiling.memory import exceed

        path = as_path(path, "write")
        fmt = format_of(path)
        holds = set(fmt.holds) if fmt is not None else set()
        kept = self.kept
        kept.check_open()
        if fmt is not None and fmt.streamed:
            check_output(path, overwrite=overwrite)
            kept.write_points(path, overwrite=overwrite)
        elif SIGNATURE in holds:
            if points:
                raise LidarSigError(f"{exceed(kept.over, kept.memory)}: its archive holds the signature without "
                                    f"per-point datasets; leave out {arg('points', True)}, or write the points as "
                                    "LAS/LAZ", path=path)
            write_archive(path, self.signature, sources=kept.run.source_records(), render=render,
                          overwrite=overwrite, tiling=kept.run.tiling_record())
        elif IMAGE in holds:
            write_signature_png(path, self.signature, mode=render, overwrite=overwrite)
        elif POINTS in holds:
            raise LidarSigError(f"{exceed(kept.over, kept.memory)}; tiles write per-point results to LAS/LAZ only: "
                                f"give a .las or .laz name, or raise {arg('memory')}", path=path)
        else:
            raise LidarSigError(f"cannot write {path.suffix.lower() or 'files without extension'}; use a point-cloud "
                                "format, .h5 or .png", path=path)

    def close(self) -> None:
        """Remove the work folder that holds the per-point values (the signature stays)."""
        self.kept.close()
