"""An area of interest: where the clouds are clipped before anything is computed.

Given as bounds ``XMIN,YMIN,XMAX,YMAX`` in the clouds' CRS (optionally followed by a CRS in
brackets, ``"... [EPSG:4326]"``, as QGIS writes an extent), as a tuple of four numbers, or as a
polygon file: a GeoPackage (every polygon and multipolygon of its feature layers, read with
sqlite3 from the GeoPackageBinary header and the WKB that follows) or a GeoJSON file (Polygon
and MultiPolygon geometries, features and collections; in WGS 84 longitude/latitude as RFC 7946
says, or in the CRS its legacy ``crs`` member names). A polygon file in another CRS than the
clouds' is reprojected (pyproj), its edges densified so that a reprojected edge follows its
curve. A point is in the area when it is inside a polygon (holes excluded; even-odd rule) or
within the bounds (edges included, as PDAL's ``bounds`` take them).
"""
from __future__ import annotations

import json
import os
import re
import sqlite3
import struct
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..base.errors import LidarSigError, arg, brief

#: Polygon files read: GeoPackage and GeoJSON.
POLYGON_EXTENSIONS = (".gpkg", ".geojson", ".json")
#: Points added on each polygon edge before reprojection (a straight edge in one CRS is a curve in another).
DENSIFY = 16
_NUMBER = r"\s*[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?\s*"
_BOUNDS = re.compile(rf"^({_NUMBER}),({_NUMBER}),({_NUMBER}),({_NUMBER})(?:\[(.+)\])?\s*$")


@dataclass(frozen=True)
class Area:
    """An area of interest: ``polygons`` (each a list of rings (K, 2), the first the outer one),
    or a box when ``box`` (the polygon is then its rectangle), in ``crs`` (text pyproj reads;
    None: the clouds' own CRS); ``said`` is how it was given, for messages and summaries."""

    polygons: tuple
    crs: str | None
    said: str
    box: bool = False

    @property
    def bounds(self) -> tuple[float, float, float, float]:
        """(xmin, ymin, xmax, ymax) of every polygon."""
        every = np.vstack([ring for poly in self.polygons for ring in poly])
        (x0, y0), (x1, y1) = every.min(axis=0), every.max(axis=0)
        return float(x0), float(y0), float(x1), float(y1)

    def meets(self, lo: Any, hi: Any) -> bool:
        """Whether the box ``lo``-``hi`` (x, y first) meets the area's bounds (edges included)."""
        x0, y0, x1, y1 = self.bounds
        return bool(lo[0] <= x1 and hi[0] >= x0 and lo[1] <= y1 and hi[1] >= y0)

    def contains(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """(N,) bool: the points ``x``, ``y`` (in the area's CRS) inside the area."""
        x, y = np.asarray(x, np.float64), np.asarray(y, np.float64)
        x0, y0, x1, y1 = self.bounds
        inside = (x >= x0) & (x <= x1) & (y >= y0) & (y <= y1)
        if self.box or not inside.any():
            return inside
        out = np.zeros(len(x), bool)
        where = np.flatnonzero(inside)
        for poly in self.polygons:
            odd = np.zeros(len(where), bool)
            for ring in poly:  # even-odd over every ring of the polygon: holes are out
                odd ^= _crossings(ring, x[where], y[where])
            out[where] |= odd
        return out

    def in_crs(self, crs: str | None) -> Area:
        """The area in the clouds' CRS ``crs`` (WKT or None): as it is when it has no CRS of its
        own or the same, else reprojected. Refuses an area in a CRS when the clouds have none,
        and a CRS pyproj does not know."""
        if self.crs is None:
            return self
        from ..method.crs import same_crs

        target = _horizontal(crs, self.said) if crs is not None else None
        source = _horizontal(self.crs, self.said)
        if target is None:
            raise LidarSigError(f"the area {self.said} is in {source.name}, but the clouds have no CRS; give the "
                                f"area as bounds in the clouds' coordinates")
        if same_crs(source.to_wkt(), target.to_wkt()):
            return Area(self.polygons, None, self.said, self.box)
        import pyproj

        to = pyproj.Transformer.from_crs(source, target, always_xy=True)
        polygons = []
        for poly in self.polygons:
            rings = []
            for ring in poly:
                dense = _densified(ring)
                x, y = to.transform(dense[:, 0], dense[:, 1])
                if not (np.all(np.isfinite(x)) and np.all(np.isfinite(y))):
                    raise LidarSigError(f"the area {self.said} cannot be reprojected from {source.name} to "
                                        f"{target.name} (it lies outside the clouds' CRS); check its CRS")
                rings.append(np.column_stack([x, y]))
            polygons.append(rings)
        return Area(tuple(polygons), None, self.said, False)

    def describe(self) -> str:
        """The area for a summary line: its bounds in the clouds' CRS, and how it was given."""
        x0, y0, x1, y1 = self.bounds
        if self.box:  # bounds in the clouds' CRS: as given
            return f"bounds {x0:.2f},{y0:.2f},{x1:.2f},{y1:.2f}"
        return f"polygon within {x0:.2f},{y0:.2f},{x1:.2f},{y1:.2f} ({self.said})"


def area_of(value: Any) -> Area | None:
    """The :class:`Area` of an ``aoi`` argument: None, an Area, four numbers (xmin, ymin, xmax,
    ymax), a text ``"XMIN,YMIN,XMAX,YMAX"`` (optionally ``" [CRS]"``), or the path of a
    GeoPackage or GeoJSON polygon file. Refuses anything else in one line."""
    if value is None or isinstance(value, Area):
        return value
    if isinstance(value, (tuple, list)) and len(value) == 4:
        try:
            numbers = [float(v) for v in value]
        except (TypeError, ValueError):
            raise LidarSigError(f"{arg('aoi')} takes four numbers XMIN,YMIN,XMAX,YMAX, got {brief(value)}") from None
        return _box(numbers, None, ",".join(f"{v:g}" for v in numbers))
    if not isinstance(value, (str, os.PathLike)) or not str(value).strip():
        raise LidarSigError(f"{arg('aoi')} takes XMIN,YMIN,XMAX,YMAX or a .gpkg/.geojson polygon file, got "
                            f"{brief(value)}")
    text = str(value)
    found = _BOUNDS.match(text)
    if found:
        crs = found.group(5).strip() if found.group(5) else None
        return _box([float(found.group(k)) for k in range(1, 5)], crs, text.strip())
    path = Path(text)
    if path.suffix.lower() not in POLYGON_EXTENSIONS:
        if "," in text:
            raise LidarSigError(f"{arg('aoi')} {text!r} is not four numbers XMIN,YMIN,XMAX,YMAX; give e.g. "
                                "770500,6277500,770520,6277520")
        raise LidarSigError(f"{arg('aoi')} is neither bounds XMIN,YMIN,XMAX,YMAX nor a polygon file "
                            f"({', '.join(POLYGON_EXTENSIONS)}); give one of them", path=path)
    if not path.is_file():
        raise LidarSigError(f"{arg('aoi')}: no such polygon file; check the path", path=path)
    polygons, crs = _geopackage(path) if path.suffix.lower() == ".gpkg" else _geojson(path)
    if not polygons:
        raise LidarSigError(f"{arg('aoi')}: the file holds no polygon; give a file of polygons (Polygon or "
                            "MultiPolygon)", path=path)
    if crs is not None:
        _horizontal(crs, path.name)  # an unknown CRS is said now, not after the clouds are read
    return Area(tuple(polygons), crs, path.name)


def _box(numbers, crs, said):
    x0, y0, x1, y1 = numbers
    if not all(np.isfinite(numbers)) or not (x0 < x1 and y0 < y1):
        raise LidarSigError(f"{arg('aoi')} {said!r}: give XMIN,YMIN,XMAX,YMAX with XMIN < XMAX and YMIN < YMAX")
    if crs is not None:
        _horizontal(crs, said)
    ring = np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1], [x0, y0]], np.float64)
    return Area(([ring],), crs, said, box=True)


def _horizontal(crs, said):
    """The pyproj CRS of ``crs`` (its horizontal part when compound); refuses an unknown one."""
    import pyproj

    try:
        parsed = pyproj.CRS.from_user_input(crs)
    except pyproj.exceptions.CRSError:
        raise LidarSigError(f"the area {said}: unknown CRS {brief(str(crs))}; give an EPSG code (EPSG:2154) or "
                            "WKT pyproj reads") from None
    return parsed.sub_crs_list[0] if parsed.is_compound else parsed


def _crossings(ring, x, y):
    """(N,) bool: whether a ray from each point towards +x crosses ``ring`` an odd number of times."""
    odd = np.zeros(len(x), bool)
    xa, ya = ring[:-1, 0], ring[:-1, 1]
    xb, yb = ring[1:, 0], ring[1:, 1]
    for k in range(len(xa)):  # edges one at a time: memory stays (N,)
        straddles = (ya[k] > y) != (yb[k] > y)
        if not straddles.any():
            continue
        at = xa[k] + (y - ya[k]) * (xb[k] - xa[k]) / np.where(yb[k] == ya[k], 1.0, yb[k] - ya[k])
        odd ^= straddles & (x < at)
    return odd


def _densified(ring):
    """``ring`` with DENSIFY points added on each edge."""
    t = np.linspace(0.0, 1.0, DENSIFY + 1)[:-1]
    a, b = ring[:-1], ring[1:]
    pts = (a[:, None, :] + (b - a)[:, None, :] * t[None, :, None]).reshape(-1, 2)
    return np.vstack([pts, ring[-1:]])


def _closed(ring):
    ring = np.asarray(ring, np.float64).reshape(-1, 2)
    if len(ring) and not np.array_equal(ring[0], ring[-1]):
        ring = np.vstack([ring, ring[:1]])
    return ring


def _geojson(path):
    """(polygons, CRS) of a GeoJSON file."""
    try:
        doc = json.loads(path.read_text(encoding="utf-8-sig"))
    except (OSError, ValueError) as exc:
        raise LidarSigError(f"{arg('aoi')}: cannot be read as GeoJSON ({type(exc).__name__}: {exc}); give a "
                            "GeoJSON file of polygons", path=path) from None
    crs = "OGC:CRS84"  # RFC 7946: longitude, latitude on WGS 84
    named = doc.get("crs", {}) if isinstance(doc, dict) else {}
    if isinstance(named, dict) and isinstance(named.get("properties"), dict) and named["properties"].get("name"):
        crs = str(named["properties"]["name"])
    polygons = []

    def walk(obj):
        if not isinstance(obj, dict):
            return
        kind = obj.get("type")
        if kind == "FeatureCollection":
            for f in obj.get("features") or ():
                walk(f)
        elif kind == "Feature":
            walk(obj.get("geometry"))
        elif kind == "GeometryCollection":
            for g in obj.get("geometries") or ():
                walk(g)
        elif kind in ("Polygon", "MultiPolygon"):
            parts = [obj.get("coordinates")] if kind == "Polygon" else obj.get("coordinates") or []
            try:
                for poly in parts:
                    rings = [_closed(np.asarray(ring, np.float64)[:, :2]) for ring in poly]
                    if rings and len(rings[0]) >= 4:
                        polygons.append(rings)
            except (TypeError, ValueError, IndexError):
                raise LidarSigError(f"{arg('aoi')}: a {kind} has coordinates that are not [x, y] pairs; fix the "
                                    "file", path=path) from None

    walk(doc)
    return polygons, crs


def _geopackage(path):
    """(polygons, CRS) of every feature layer of a GeoPackage (the CRS of the first layer with
    polygons; layers in other CRSs are refused)."""
    try:
        con = sqlite3.connect(f"file:{path}?mode=ro", uri=True)
        try:
            layers = con.execute("SELECT g.table_name, g.column_name, g.srs_id, s.organization, "
                                 "s.organization_coordsys_id, s.definition FROM gpkg_geometry_columns g "
                                 "LEFT JOIN gpkg_spatial_ref_sys s ON s.srs_id = g.srs_id").fetchall()
            polygons, crs_of = [], []
            for table, column, srs_id, org, code, definition in layers:
                found = []
                for (blob,) in con.execute(f'SELECT "{column}" FROM "{table}"'):
                    if blob:
                        found += _wkb_polygons(_gpkg_wkb(bytes(blob)))
                if found:
                    polygons += found
                    crs_of.append(_gpkg_crs(srs_id, org, code, definition))
        finally:
            con.close()
    except (sqlite3.Error, struct.error, ValueError) as exc:
        raise LidarSigError(f"{arg('aoi')}: cannot be read as a GeoPackage of polygons ({type(exc).__name__}: "
                            f"{exc}); give a GeoPackage as GDAL or QGIS write it", path=path) from None
    if len(set(crs_of)) > 1:
        raise LidarSigError(f"{arg('aoi')}: its polygon layers are in different CRSs; keep one layer", path=path)
    return polygons, (crs_of[0] if crs_of else None)


def _gpkg_crs(srs_id, org, code, definition):
    """The CRS of a GeoPackage SRS row; None for the undefined ones (taken in the clouds' CRS)."""
    if srs_id is None or srs_id in (-1, 0):
        return None
    if org and str(org).upper() == "EPSG" and code is not None:
        return f"EPSG:{int(code)}"
    return definition if definition and definition != "undefined" else None


def _gpkg_wkb(blob):
    """The WKB of a GeoPackageBinary blob: after the "GP" header and its envelope."""
    if blob[:2] != b"GP":
        raise ValueError("a geometry without the GeoPackageBinary header")
    flags = blob[3]
    envelope = {0: 0, 1: 32, 2: 48, 3: 48, 4: 64}.get((flags >> 1) & 0b111)
    if envelope is None:
        raise ValueError("a geometry header with an unknown envelope kind")
    return blob[8 + envelope:]


def _wkb_polygons(wkb):
    """The polygons (lists of rings (K, 2)) of a WKB geometry: Polygon, MultiPolygon and
    GeometryCollection, with Z and M (ISO codes 1000-3000 and the EWKB flags) dropped."""
    polygons: list = []
    _wkb_read(memoryview(wkb), 0, polygons)
    return polygons


def _wkb_read(buf, at, polygons):
    """Read one WKB geometry at ``at``, appending its polygons; return where it ends."""
    order = "<" if buf[at] == 1 else ">"
    (code,) = struct.unpack_from(order + "I", buf, at + 1)
    at += 5
    has_z, has_m = bool(code & 0x80000000), bool(code & 0x40000000)
    if code & 0x20000000:  # EWKB with an SRID
        at += 4
    code &= 0x0FFFFFFF
    kind, dims = code % 1000, code // 1000
    has_z, has_m = has_z or dims in (1, 3), has_m or dims in (2, 3)
    width = 2 + has_z + has_m
    if kind == 1:
        return at + 8 * width
    if kind == 2:
        (n,) = struct.unpack_from(order + "I", buf, at)
        return at + 4 + 8 * width * n
    if kind == 3:
        (n_rings,) = struct.unpack_from(order + "I", buf, at)
        at += 4
        rings = []
        for _ in range(n_rings):
            (n,) = struct.unpack_from(order + "I", buf, at)
            values = np.frombuffer(buf, dtype=order + "f8", count=n * width, offset=at + 4).reshape(n, width)
            rings.append(_closed(values[:, :2].copy()))
            at += 4 + 8 * width * n
        if rings and len(rings[0]) >= 4:
            polygons.append(rings)
        return at
    if kind in (4, 5, 6, 7):
        (n,) = struct.unpack_from(order + "I", buf, at)
        at += 4
        for _ in range(n):
            at = _wkb_read(buf, at, polygons if kind in (6, 7) else [])
        return at
    raise ValueError(f"WKB geometry type {code} is not read")
