"""`Catalog`: a survey catalogue opened, its tiles and their signatures, and the questions asked
of it: the tiles most like a query (:meth:`Catalog.similar`), the tiles unlike their neighbours
and the survey (:meth:`Catalog.outliers`), the matrix of distances (:meth:`Catalog.distances`).
"""
from __future__ import annotations

import json
import os
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ..base.errors import LidarSigError, a_kind, as_path, counted
from ..metrics import METRIC
from ..method.scales import recorded_scales
from ._distances import SCREENING, combine, metric_keys, pair_metrics, screening
from ._features import Features, sg_image, signature_features

if TYPE_CHECKING:
    from ..method.signature_raster import Signature
    from ._outlier_scores import Outliers
    from ._similar_tiles import Similar


@dataclass(repr=False)
class Query:
    """What a catalogue is asked about: its name, kind ("tile", "cloud" or "archive"), its
    :class:`~lidar_sig.survey_catalog._features.Features` (one row), its Sg image, and its row in the
    catalogue when it is one of its tiles."""

    name: str
    kind: str
    features: Features
    sg: np.ndarray
    index: int | None = None

    def __repr__(self):
        from ..base.views import one_line

        return one_line(f"<Query {self.name} ({self.kind})>")


@dataclass(repr=False)
class Distances:
    """A labelled matrix of distances between the tiles of a catalogue: ``values[i, j]`` between
    ``names[i]`` and ``names[j]``, of ``metric`` (a metric's key, "screening" or "distance")."""

    names: list
    values: np.ndarray
    metric: str

    #: Tiles whose rows and columns a card's table shows, at most (the picture shows them all).
    SHOWN = 10

    def _between(self):
        """The values between different tiles (the diagonal left out)."""
        n = len(self.names)
        return self.values[~np.eye(n, dtype=bool)] if n > 1 else np.empty(0)

    def __repr__(self):
        from ..base.views import one_line

        between = self._between()
        between = between[np.isfinite(between)]
        spread = (f"; {between.min():.3g} to {between.max():.3g} between tiles, median {np.median(between):.3g}"
                  if len(between) else "")
        return one_line(f"<Distances {len(self.names)} x {len(self.names)} tiles, {self.metric}{spread}>")

    def picture(self, size: int = 160) -> np.ndarray:
        """RGB picture of the matrix, about ``size`` pixels a side: row i, column j the value
        between tiles i and j (catalogue order), white (least) to dark blue (most) over the
        values between different tiles."""
        n = len(self.names)
        between = self._between()
        between = between[np.isfinite(between)]
        lo, hi = (float(between.min()), float(between.max())) if len(between) else (0.0, 1.0)
        t = np.clip((np.nan_to_num(self.values, nan=lo) - lo) / (hi - lo if hi > lo else 1.0), 0, 1)
        rgb = 1.0 - t[..., None] * np.array([0.85, 0.65, 0.35])
        k = max(1, size // max(n, 1))
        return np.repeat(np.repeat(rgb, k, axis=0), k, axis=1)

    def _repr_html_(self):
        """A notebook's view: the matrix as a picture and, for the first tiles, as a table."""
        from ..base.views import card

        m = min(len(self.names), self.SHOWN)
        rows = [(f"{i + 1} {self.names[i]}", *(f"{v:.3f}" for v in self.values[i, :m])) for i in range(m)]
        more = (f"the first {m} of {len(self.names)} tiles; the picture shows them all. " if len(self.names) > m
                else "")
        return card("Distances", [f"{len(self.names)} x {len(self.names)} tiles, {self.metric}"],
                    header=("tile", *(str(j + 1) for j in range(m))), rows=rows, numeric=range(1, m + 1),
                    image=self.picture(), width=160,
                    note=more + "picture: row i, column j, white (least) to dark blue (most) between tiles")

    def at(self, a: str, b: str) -> float:
        """The value between the tiles named ``a`` and ``b``."""
        return float(self.values[self.names.index(a), self.names.index(b)])

    def to_dict(self) -> dict[str, Any]:
        return {"metric": self.metric, "names": list(self.names), "values": self.values.tolist()}


class Catalog:
    """A survey catalogue (``lidar-sig catalog``, :meth:`build`): one signature per tile with its
    footprint, counts, CRS and SHA-256, made with one method.

    >>> cat = ls.Catalog("survey.h5")                        # doctest: +SKIP
    >>> cat.similar("tile_0042.laz", top=5)                  # doctest: +SKIP
    """

    def __init__(self, path: str | os.PathLike[str]) -> None:
        from ..io.catalog_file import read_catalog

        self.path = as_path(path, "Catalog")
        self.header, self.columns = read_catalog(self.path)
        columns = self.columns  # named by the archive's layout (docs/archive.md)
        self.features = Features(columns["fv"], columns["color"], columns["egeom"], columns["class_totals"],
                                 columns["n_signature"])
        self._sg = {}

    @classmethod
    def build(cls, inputs: Any, output: str | os.PathLike[str], pipeline: Any = None, **options: Any) -> Catalog:
        """Make or grow the catalogue ``output`` from LAS/LAZ tiles and folders ``inputs``
        (:func:`lidar_sig.survey_catalog._build.build_catalog`, which takes ``options``); raises a
        LidarSigError naming the tiles that failed (the others are in the catalogue)."""
        from ._build import build_catalog

        run = build_catalog(inputs, output, pipeline, **options)
        if not run.complete:
            raise LidarSigError("some tiles could not be computed (the others are in the catalogue): "
                                + "; ".join(run.missing), path=output)
        return cls(run.output)

    # -- the tiles -----------------------------------------------------------------------

    def __len__(self):
        return len(self.columns["name"])

    def __repr__(self):
        from ..base.views import one_line

        m = self.method
        return one_line(f"<Catalog {self.path}: {counted(len(self), 'tile')}, {m.get('descriptor', '?')} "
                        f"{m.get('strategy', '?')}, classes {self.classes.name}>")

    def _repr_html_(self):
        """A notebook's view: the method, and the tiles with their points, area and density."""
        from ..base.views import card

        m = self.method
        c = self.columns
        rows = [(name, f"{int(n):,}", f"{float(a):,.0f}", f"{float(d):.1f}")
                for name, n, a, d in zip(c["name"][:12], c["n_points"][:12], c["area"][:12], c["density"][:12])]
        more = f"... and {len(self) - 12:,} more tiles" if len(self) > 12 else ""
        return card(f"Catalog {self.path.name}", [f"{counted(len(self), 'tile')}, {m.get('descriptor', '?')} "
                                                  f"{m.get('strategy', '?')}, class table {self.classes.name}"],
                    header=("tile", "points", "area m²", "points/m²"), rows=rows, numeric=(1, 2, 3), note=more)

    @property
    def names(self) -> list[str]:
        """The tiles' file names, in the catalogue's order."""
        return list(self.columns["name"])

    @property
    def paths(self) -> list[str]:
        return list(self.columns["path"])

    @property
    def method(self) -> dict[str, Any]:
        """The method every tile's signature was made with (as :meth:`Pipeline.method`)."""
        return dict(self.header["method"])

    @property
    def classes(self):
        return self.header["classes"]

    @property
    def frame(self):
        return self.header["frame"]

    @property
    def spread(self):
        """Each metric's spread over the catalogue's pairs (:mod:`lidar_sig.survey_catalog._distances`)."""
        return dict(self.header["spread"])

    @property
    def labelled(self):
        return bool(self.classes.names)

    @property
    def keys(self):
        """The metrics the catalogue compares (METRIC_KEYS, without the semantic ones when
        unlabelled): those it holds a spread of (a metric installed after it was made is not)."""
        return tuple(k for k in metric_keys(self.labelled) if k in self.header["spread"])

    def summary(self) -> list[str]:
        """Lines describing the catalogue, for `lidar-sig info` (it was checked when opened)."""
        from ..method.crs import crs_name

        m, c = self.method, self.columns
        recorded = recorded_scales(m)
        scales = recorded.describe() if recorded is not None else "scales ?"
        crs = [crs_name(w) or "none" for w in self.header["crs"]]
        lines = [f"{self.path}: lidar_sig survey catalogue, {counted(len(self), 'tile')}",
                 f"  descriptor {m['descriptor']}, strategy {m['strategy']}, {scales}, {m['weights']} weights",
                 f"  signatures: {counted(int(c['n_signature'].sum()), 'point')}, "
                 f"{int(c['n_undefined'].sum()):,} undefined, frame {self.frame.size} px, "
                 f"class table {self.classes.name!r}",
                 f"  CRS: {', '.join(crs)}"]
        lines += [f"  tile {name}: {int(n):,} points" for name, n in zip(c["name"][:10], c["n_points"][:10])]
        if len(self) > 10:
            lines.append(f"  ... {counted(len(self) - 10, 'more tile')} (`lidar-sig outliers {self.path} --json`)")
        return lines

    def crs_of(self, i):
        """Tile ``i``'s CRS as WKT, or None."""
        return self.header["crs"][int(self.columns["crs"][i])] or None

    def tile(self, i: int) -> dict[str, Any]:
        """Tile ``i``'s facts (by row, name or path): name, path, SHA-256, CRS name, points,
        density, bounds, area."""
        from ..method.crs import crs_name

        i = self._row(i)  # a negative row counted from the end: another tile than meant
        c = self.columns
        return {"name": c["name"][i], "path": c["path"][i], "sha256": c["sha256"][i],
                "crs": crs_name(self.crs_of(i)), "points": int(c["n_points"][i]),
                "undefined": int(c["n_undefined"][i]), "density": float(c["density"][i]),
                "area_m2": float(c["area"][i]), "bounds": [float(v) for v in c["bounds"][i]]}

    def index(self, name: str) -> int:
        """The row of the tile given by file name, stem or path; None when none matches; a
        LidarSigError when a name matches several tiles."""
        if isinstance(name, (int, np.integer)) and not isinstance(name, bool):
            return int(name) if 0 <= name < len(self) else None
        text = str(name)
        resolved = str(Path(text).resolve()) if text else ""
        hits = [i for i, (n, p) in enumerate(zip(self.columns["name"], self.columns["path"]))
                if text == n or p == resolved or text == n.rsplit(".", 1)[0]]
        if len(hits) > 1:
            raise LidarSigError(f"{text!r} names {len(hits)} tiles of the catalogue ("
                                + ", ".join(self.columns["path"][i] for i in hits) + "); give its path")
        return hits[0] if hits else None

    def counts(self, rows):
        """{row: (C, H, W) int64 count raster} of the tiles ``rows`` (rows, names or paths, as
        for :meth:`tile`; a LidarSigError names one the catalogue does not hold)."""
        from ..io.catalog_file import read_counts

        shape = (len(self.classes), self.frame.size, self.frame.size)
        out = {}
        for i, (at, values) in read_counts(self.path, self._rows(rows), self.columns["counts_offsets"]).items():
            flat = np.zeros(int(np.prod(shape)), np.int64)
            flat[at] = values
            out[i] = flat.reshape(shape)
        return out

    def signature(self, tile: int | str) -> Signature:
        """The signature of a tile (by row, name or path): compares like the tile's own."""
        from ..method.signature_raster import Signature

        i = self._row(tile)
        c = self.columns
        meta = json.loads(c["meta"][i])
        metadata = {**self.method, "source": c["name"][i], "n_points": int(c["n_points"][i]),
                    "n_undefined": int(c["n_undefined"][i]), "crs": self.crs_of(i),
                    "resolved_scales": meta.get("resolved_scales", []), "units": meta.get("units"),
                    "n_capped": meta.get("n_capped", 0), "n_duplicates": meta.get("n_duplicates", 0)}
        return Signature(self.counts([i])[i], self.frame, self.classes, c["egeom"][i].astype(np.int64),
                         int(c["n_undefined"][i]), metadata, c["class_totals"][i].astype(np.int64))

    def total_rasters(self, rows):
        """{row: (H, W) float64 points per pixel, all classes} of the tiles ``rows`` (as for
        :meth:`counts`)."""
        from ..io.catalog_file import read_counts

        pixels = self.frame.size ** 2
        rows = self._rows(rows)
        return {i: np.bincount(at % pixels, weights=values, minlength=pixels).reshape(self.frame.size, -1)
                for i, (at, values) in read_counts(self.path, rows, self.columns["counts_offsets"]).items()}

    def sg(self, rows):
        """{row: Sg image} of the tiles ``rows`` (as for :meth:`counts`; made from their counts,
        kept once made)."""
        rows = self._rows(rows)
        todo = [i for i in rows if i not in self._sg]
        for i, total in self.total_rasters(todo).items():
            self._sg[i] = sg_image(total, self.features.n_points[i], self.frame)
        return {i: self._sg[i] for i in rows}

    def _rows(self, tiles):
        """The rows of ``tiles`` (one tile, or a list or array of rows, names or paths), each
        checked as by :meth:`_row`: a negative row would be another tile, counted from the end."""
        if isinstance(tiles, (str, int, np.integer)):
            tiles = [tiles]
        try:
            tiles = list(tiles)
        except TypeError:
            raise LidarSigError(f"rows must be a list of the catalogue's rows or tile names, got {a_kind(tiles)}") \
                from None
        return [self._row(t.item() if isinstance(t, np.generic) else t) for t in tiles]

    def _row(self, tile):
        i = self.index(tile)
        if i is None and isinstance(tile, (int, np.integer)) and not isinstance(tile, bool):
            raise LidarSigError(f"no tile at row {tile} of the catalogue {self.path}: it holds "
                                f"{counted(len(self), 'tile')} (rows 0 to {len(self) - 1})")
        if i is None:
            raise LidarSigError(f"no tile {tile!r} in the catalogue {self.path}; `lidar-sig outliers "
                                f"{self.path} --json` lists its tiles")
        return i

    # -- queries -------------------------------------------------------------------------

    def query(self, query: Any, *, columns: Any = None) -> Query:
        """A :class:`Query` from a tile of the catalogue (name, stem or path), a point-cloud file
        (computed with the catalogue's method), an archive (.h5, made with the same method), a
        PointCloud or a Signature."""
        from ..method.cloud import PointCloud
        from ..method.signature_raster import Signature

        if isinstance(query, str) and not query.strip():
            raise LidarSigError("the query is empty; give a tile's name, a cloud or an archive")
        if isinstance(query, (str, Path, int, np.integer)) and not isinstance(query, bool):
            # a file given is that file, even where a tile has its name: the tile only when it is that file
            on_disk = isinstance(query, (str, Path)) and os.path.lexists(query)
            i = self.index(str(Path(query).resolve())) if on_disk else self.index(query)
            if i is not None:
                return Query(self.columns["name"][i], "tile", self.features.row(i), self.sg([i])[i], i)
            if isinstance(query, (int, np.integer)):
                raise LidarSigError(f"no tile at row {query} of the catalogue {self.path}: it holds "
                                    f"{counted(len(self), 'tile')} (rows 0 to {len(self) - 1})")
        if isinstance(query, Signature):
            return self._query_of(query, query.metadata.get("source") or "(in memory)", "archive")
        if isinstance(query, PointCloud):
            return self._query_of(self._run(query), query.path or "(in memory)", "cloud")
        if not isinstance(query, (str, Path)):
            raise LidarSigError(f"cannot query a catalogue with {a_kind(query)}; give a tile's name, a "
                                "file path, a PointCloud or a Signature")
        from ..io import HDF5_EXTENSIONS, load_signature, read

        path = Path(query)
        if not os.path.exists(path):  # False, not OSError, for a name longer than a file system takes
            raise LidarSigError(f"is neither a tile of the catalogue {self.path} nor a file; give a tile's name "
                                "(`lidar-sig outliers CATALOGUE --json` lists them) or a cloud or archive", path=query)
        if path.suffix.lower() in HDF5_EXTENSIONS:
            return self._query_of(load_signature(path), str(query), "archive")
        cloud = read(path, columns=columns)
        return self._query_of(self._run(cloud), str(query), "cloud")

    def _run(self, cloud):
        """The signature of ``cloud`` with the catalogue's method (a cloud without class codes,
        or whose codes are all 0, counted in class 0, as the catalogue's tiles are)."""
        from ..pipeline.flow import Pipeline

        if cloud.labels is None:
            cloud.labels = np.zeros(len(cloud), np.int64)
            k = int(self.classes.index(np.zeros(1, np.int64))[0])
            if np.delete(np.asarray(self.columns["class_totals"]), k, axis=1).any():  # the tiles have classes
                import warnings

                from ..base.errors import LidarSigWarning

                warnings.warn(f"{cloud.path or 'the query'} has no class codes: its points are counted in the class "
                              "of code 0, as a tile without them is; the semantic metrics (delta_KL, L1) then "
                              "compare it as unclassified (--metric fv ranks by geometry)", LidarSigWarning,
                              stacklevel=3)
        try:
            pipe = Pipeline.from_method(self.method, classes=self.classes, frame=self.frame)
        except LidarSigError as exc:
            raise LidarSigError(f"its method record cannot be run ({exc}); the catalogue is damaged or was edited "
                                "by hand: make it again", path=self.path) from None
        return pipe.run(cloud).signature

    def _query_of(self, signature, name, kind):
        from ..method.signature_raster import method_differences

        if signature.frame != self.frame or signature.classes != self.classes \
                or len(signature.egeom_counts) != self.columns["egeom"].shape[1]:
            raise LidarSigError(f"{name} was made with another frame or class table ({_settings(signature)}) than "
                                f"the catalogue ({_settings(self)}); make it with the catalogue's settings, or give "
                                "the cloud")
        differ = method_differences(signature.metadata, self.method)
        if differ:
            raise LidarSigError(f"{name} was made with another method than the catalogue (" + "; ".join(differ)
                                + "); give the cloud itself: it is computed the catalogue's way")
        return Query(name, kind, signature_features(signature),
                     sg_image(signature.total, signature.n_points, self.frame))

    def similar(self, query: Any, *, top: int = 10, metric: str | None = None, shortlist: int | None = None,
                columns: Any = None) -> Similar:
        """The tiles nearest to ``query`` (see :meth:`query`; ``columns`` of a text cloud), best
        first (:func:`lidar_sig.survey_catalog._similar_tiles.similar`)."""
        from ._similar_tiles import similar

        return similar(self, query, top=top, metric=metric, shortlist=shortlist, columns=columns)

    def outliers(self, *, reach: float | None = None) -> Outliers:
        """Every tile scored by how unlike it is to its spatial neighbours and to the survey
        (:func:`lidar_sig.survey_catalog._outlier_scores.outliers`)."""
        from ._outlier_scores import outliers

        return outliers(self, reach=reach)

    def distances(self, metric: str | None = None) -> Distances:
        """A :class:`Distances` matrix between every pair of tiles: the screening distance
        (default, or "screening"), one metric's values (its key), or "distance", the ranking
        distance of :meth:`similar` (every metric: image metrics for all N^2 / 2 pairs, the costly
        part; docs/performance.md)."""
        metric = metric or "screening"
        keys = self.keys
        if metric not in ("screening", "distance") + keys:
            raise LidarSigError(f"unknown metric {metric!r}; use screening, distance or one of {', '.join(keys)}")
        n = len(self)
        if metric in ("screening",) + SCREENING:
            values = screening(self.features, self.features, self.labelled)
            matrix = combine(values, self.spread, tuple(values)) if metric == "screening" else values[metric]
        else:
            wanted = keys if metric == "distance" else (metric,)
            images = self.sg(range(n))
            matrix = np.zeros((n, n))
            for i in range(n):
                for j in range(i + 1, n):
                    v = pair_metrics(self.features.row(i), self.features.row(j), images[i], images[j],
                                     self.frame.mask(), wanted)
                    matrix[i, j] = matrix[j, i] = (combine(v, self.spread, wanted) if metric == "distance"
                                                   else v[metric])
        matrix = np.array(matrix, dtype=np.float64)
        # a tile against itself: the metric's value of identical signatures (1 for s_SSIM), 0 for a distance
        np.fill_diagonal(matrix, METRIC[metric].same if metric in METRIC else 0.0)
        return Distances(self.names, matrix, metric)


def _settings(made):
    """The frame and class table of a signature or catalogue, as said in a message: the table's
    noise codes too, which tell two tables of one name apart."""
    noise = ", ".join(map(str, made.classes.noise)) or "none"
    return f"{made.frame.size} px, class table {made.classes.name!r} with noise codes {noise}"
