"""GeoPackage files of polygons with attributes (OGC GeoPackage 1.2 vector features), written with
the standard library's sqlite3: GDAL, QGIS and ArcGIS open them as layers.

A GeoPackage is an SQLite database with ``application_id`` 'GPKG' and ``user_version`` 10200,
the tables ``gpkg_spatial_ref_sys`` (CRSs), ``gpkg_contents`` (the layers) and
``gpkg_geometry_columns``, and one table per layer whose geometry column holds GeoPackageBinary
blobs: the "GP" header (version, flags, SRS id, envelope) followed by the geometry as
well-known binary (WKB). Each layer gets:

- a **spatial index**: the R*Tree of the ``gpkg_rtree_index`` extension (a virtual table
  ``rtree_<layer>_geom`` of the features' envelopes, registered in ``gpkg_extensions``, with the
  triggers the specification defines, which keep it up to date when a GIS edits the layer), so
  that QGIS and GDAL read only the features in view;
- its **default style**, when given: a row of the ``layer_styles`` table, the QGIS convention
  (QGIS draws the layer with it when it opens the layer; :mod:`lidar_sig.io.styles`).

Written atomically (:mod:`lidar_sig.io.atomic`).
"""
from __future__ import annotations

import sqlite3
import struct
import warnings
from dataclasses import dataclass, field

import numpy as np

from ..base.errors import LidarSigError, LidarSigWarning
from .atomic import atomic_output

APPLICATION_ID = 0x47504B47  # "GPKG"
USER_VERSION = 10200  # GeoPackage 1.2.0: read by every GDAL since 2.2 (the tables are the same in 1.4)
#: SRS ids the specification requires, and the first id given to a CRS without an EPSG code.
UNDEFINED_CARTESIAN, UNDEFINED_GEOGRAPHIC, CUSTOM_SRS = -1, 0, 100000
_WGS84 = ('GEOGCS["WGS 84",DATUM["WGS_1984",SPHEROID["WGS 84",6378137,298.257223563]],PRIMEM["Greenwich",0],'
          'UNIT["degree",0.0174532925199433],AXIS["Latitude",NORTH],AXIS["Longitude",EAST],AUTHORITY["EPSG","4326"]]')

_SCHEMA = """
CREATE TABLE gpkg_spatial_ref_sys (srs_name TEXT NOT NULL, srs_id INTEGER PRIMARY KEY, organization TEXT NOT NULL,
  organization_coordsys_id INTEGER NOT NULL, definition TEXT NOT NULL, description TEXT);
CREATE TABLE gpkg_contents (table_name TEXT NOT NULL PRIMARY KEY, data_type TEXT NOT NULL, identifier TEXT UNIQUE,
  description TEXT DEFAULT '', last_change DATETIME NOT NULL DEFAULT (strftime('%Y-%m-%dT%H:%M:%fZ','now')),
  min_x DOUBLE, min_y DOUBLE, max_x DOUBLE, max_y DOUBLE, srs_id INTEGER,
  CONSTRAINT fk_gc_r_srs_id FOREIGN KEY (srs_id) REFERENCES gpkg_spatial_ref_sys(srs_id));
CREATE TABLE gpkg_geometry_columns (table_name TEXT NOT NULL, column_name TEXT NOT NULL,
  geometry_type_name TEXT NOT NULL, srs_id INTEGER NOT NULL, z TINYINT NOT NULL, m TINYINT NOT NULL,
  CONSTRAINT pk_geom_cols PRIMARY KEY (table_name, column_name), CONSTRAINT uk_gc_table_name UNIQUE (table_name),
  CONSTRAINT fk_gc_tn FOREIGN KEY (table_name) REFERENCES gpkg_contents(table_name),
  CONSTRAINT fk_gc_srs FOREIGN KEY (srs_id) REFERENCES gpkg_spatial_ref_sys (srs_id));
CREATE TABLE gpkg_extensions (table_name TEXT, column_name TEXT, extension_name TEXT NOT NULL,
  definition TEXT NOT NULL, scope TEXT NOT NULL, CONSTRAINT ge_tce UNIQUE (table_name, column_name, extension_name));
"""
#: The R*Tree extension's definition and the triggers that keep an index up to date (GeoPackage
#: 1.2, annex F.3); ``{t}`` the layer, ``{i}`` its index. ST_IsEmpty, ST_MinX, ... are functions
#: the GIS that edits the layer provides (GDAL does): the index is filled here before they are made.
RTREE = "http://www.geopackage.org/spec120/#extension_rtree"
_RTREE_TRIGGERS = """
CREATE TRIGGER "{i}_insert" AFTER INSERT ON "{t}" WHEN (new."geom" NOT NULL AND NOT ST_IsEmpty(NEW."geom"))
  BEGIN INSERT OR REPLACE INTO "{i}" VALUES (NEW."fid", ST_MinX(NEW."geom"), ST_MaxX(NEW."geom"),
  ST_MinY(NEW."geom"), ST_MaxY(NEW."geom")); END;
CREATE TRIGGER "{i}_update1" AFTER UPDATE OF "geom" ON "{t}" WHEN OLD."fid" = NEW."fid" AND
  (NEW."geom" NOTNULL AND NOT ST_IsEmpty(NEW."geom")) BEGIN INSERT OR REPLACE INTO "{i}" VALUES (NEW."fid",
  ST_MinX(NEW."geom"), ST_MaxX(NEW."geom"), ST_MinY(NEW."geom"), ST_MaxY(NEW."geom")); END;
CREATE TRIGGER "{i}_update2" AFTER UPDATE OF "geom" ON "{t}" WHEN OLD."fid" = NEW."fid" AND
  (NEW."geom" ISNULL OR ST_IsEmpty(NEW."geom")) BEGIN DELETE FROM "{i}" WHERE id = OLD."fid"; END;
CREATE TRIGGER "{i}_update3" AFTER UPDATE ON "{t}" WHEN OLD."fid" != NEW."fid" AND
  (NEW."geom" NOTNULL AND NOT ST_IsEmpty(NEW."geom")) BEGIN DELETE FROM "{i}" WHERE id = OLD."fid";
  INSERT OR REPLACE INTO "{i}" VALUES (NEW."fid", ST_MinX(NEW."geom"), ST_MaxX(NEW."geom"), ST_MinY(NEW."geom"),
  ST_MaxY(NEW."geom")); END;
CREATE TRIGGER "{i}_update4" AFTER UPDATE ON "{t}" WHEN OLD."fid" != NEW."fid" AND
  (NEW."geom" ISNULL OR ST_IsEmpty(NEW."geom")) BEGIN DELETE FROM "{i}" WHERE id IN (OLD."fid", NEW."fid"); END;
CREATE TRIGGER "{i}_delete" AFTER DELETE ON "{t}" WHEN old."geom" NOT NULL
  BEGIN DELETE FROM "{i}" WHERE id = OLD."fid"; END;
"""
#: The table of QGIS styles in a GeoPackage, as QGIS makes it.
_LAYER_STYLES = """
CREATE TABLE layer_styles (id INTEGER PRIMARY KEY AUTOINCREMENT NOT NULL, f_table_catalog TEXT(256),
  f_table_schema TEXT(256), f_table_name TEXT(256), f_geometry_column TEXT(256), styleName TEXT(30), styleQML TEXT,
  styleSLD TEXT, useAsDefault BOOLEAN, description TEXT, owner TEXT(30), ui TEXT(30),
  update_time DATETIME DEFAULT (strftime('%Y-%m-%dT%H:%M:%fZ','now')));
"""


@dataclass
class Layer:
    """One layer of polygons: its table ``name``, ``crs`` (WKT or None), ``features`` [(ring (K,
    2), {field: value})] (every feature with the same fields; values numbers, text, lists written
    as text, or None), a ``description``, SQL ``types`` of fields whose values cannot say ({field:
    "INTEGER" | "REAL" | "TEXT"}, e.g. a field that is NULL everywhere), and its default QGIS
    ``style`` (QML text, :mod:`lidar_sig.io.styles`) named ``style_name``, or None."""

    name: str
    crs: object
    features: list
    description: str = ""
    types: dict = field(default_factory=dict)
    style: str = None
    style_name: str = "default"


def polygon_blob(ring, srs_id):
    """GeoPackageBinary of a polygon with one ring (K, 2), closed here: the header (magic "GP",
    version 0, flags: little-endian, envelope [minx, maxx, miny, maxy]), then WKB Polygon."""
    ring = np.asarray(ring, np.float64).reshape(-1, 2)
    if len(ring) and not np.array_equal(ring[0], ring[-1]):
        ring = np.vstack([ring, ring[:1]])
    (x0, y0), (x1, y1) = ring.min(axis=0), ring.max(axis=0)
    flags = 0b0000_0011  # envelope kind 1 (bits 1-3), little-endian (bit 0)
    header = b"GP" + struct.pack("<BBi4d", 0, flags, int(srs_id), x0, x1, y0, y1)
    wkb = struct.pack("<BIII", 1, 3, 1, len(ring)) + ring.astype("<f8").tobytes()
    return header + wkb


def srs_record(crs, used):
    """(srs_id, name, organization, code, definition) of a CRS (WKT or None); ``used`` the ids
    taken so far (a CRS without an EPSG code gets the next custom id)."""
    if not crs:
        return UNDEFINED_CARTESIAN, "Undefined cartesian SRS", "NONE", -1, "undefined"
    import pyproj

    parsed = pyproj.CRS.from_user_input(crs)
    if parsed.is_compound:  # footprints are plan view: the horizontal member
        parsed = parsed.sub_crs_list[0]
    code = parsed.to_epsg(min_confidence=70)
    try:
        definition = parsed.to_wkt("WKT1_GDAL")
    except pyproj.exceptions.CRSError:
        definition = parsed.to_wkt()
    if code is not None:
        return int(code), parsed.name, "EPSG", int(code), definition
    srs_id = max([CUSTOM_SRS - 1, *used]) + 1
    return srs_id, parsed.name, "NONE", srs_id, definition


def _sql_type(values):
    kinds = {type(v) for v in values if v is not None}
    if kinds and kinds <= {int, bool, np.int64}:
        return "INTEGER"
    if kinds and kinds <= {int, float, np.int64, np.float64}:
        return "REAL"
    return "TEXT"


def _value(v):
    if v is None or isinstance(v, (int, float, str)):
        return v if not (isinstance(v, float) and not np.isfinite(v)) else None
    if isinstance(v, (np.integer,)):
        return int(v)
    if isinstance(v, (np.floating,)):
        return float(v) if np.isfinite(v) else None
    if isinstance(v, (list, tuple)):
        return ", ".join(map(str, v))
    return str(v)


def write_geopackage(path, layers, *, overwrite=False):
    """Write ``layers`` to the GeoPackage ``path``: a list of :class:`Layer`, or {CRS (WKT or
    None): [(ring (K, 2), {field: value}), ...]}, one layer per CRS, named "tiles" (with one CRS)
    or "tiles_<EPSG code>" (:func:`tile_layers`)."""
    from .formats import VECTOR, check_format

    check_format(path, VECTOR, said="a GeoPackage")
    if isinstance(layers, dict):
        layers = tile_layers(layers)
    with atomic_output(path, overwrite=overwrite) as tmp:
        con = sqlite3.connect(tmp)
        try:
            con.execute(f"PRAGMA application_id = {APPLICATION_ID}")
            con.execute(f"PRAGMA user_version = {USER_VERSION}")
            con.executescript(_SCHEMA)
            con.executemany("INSERT INTO gpkg_spatial_ref_sys VALUES (?, ?, ?, ?, ?, ?)", [
                ("WGS 84 geodetic", 4326, "EPSG", 4326, _WGS84, "longitude/latitude on the WGS 84 ellipsoid"),
                ("Undefined cartesian SRS", UNDEFINED_CARTESIAN, "NONE", -1, "undefined", "undefined cartesian"),
                ("Undefined geographic SRS", UNDEFINED_GEOGRAPHIC, "NONE", 0, "undefined", "undefined geographic")])
            used = []
            for layer in layers:
                srs_id, name, org, code, definition = srs_record(layer.crs, used)
                used.append(srs_id)
                if srs_id not in (UNDEFINED_CARTESIAN, 4326):
                    con.execute("INSERT OR IGNORE INTO gpkg_spatial_ref_sys VALUES (?, ?, ?, ?, ?, ?)",
                                (name, srs_id, org, code, definition, name))
                _write_layer(con, layer, srs_id)
            styled = [layer for layer in layers if layer.style]
            if styled:
                _write_styles(con, styled)
            con.commit()
        except sqlite3.Error as exc:  # a full disk: "database or disk is full"
            full = getattr(exc, "sqlite_errorname", "") == "SQLITE_FULL" or "is full" in str(exc)
            reason = "no space left on the device; free some space or write elsewhere" if full else \
                f"{exc}; check the output folder"
            raise LidarSigError(f"could not be written: {reason}", path=path) from None
        finally:
            con.close()


def tile_layers(by_crs, *, description="tile footprints (convex hulls) with their scores", style=None):
    """{CRS: features} as :class:`Layer` s, one per CRS: "tiles" when there is one CRS, else
    "tiles_<EPSG code>" ("tiles_<id>" for a CRS without one, "tiles_no_crs" without a CRS)."""
    layers, used = [], []
    for crs, features in by_crs.items():
        srs_id = srs_record(crs, used)[0]
        used.append(srs_id)
        name = "tiles" if len(by_crs) == 1 else f"tiles_{srs_id if srs_id >= 0 else 'no_crs'}"
        layers.append(Layer(name, crs, features, description, style=style))
    return layers


def _write_layer(con, layer, srs_id):
    table, features = layer.name, layer.features
    fields = list(features[0][1]) if features else list(layer.types)
    types = {f: layer.types.get(f) or _sql_type([attrs.get(f) for _, attrs in features]) for f in fields}
    columns = "".join(f', "{f}" {types[f]}' for f in fields)
    con.execute(f'CREATE TABLE "{table}" (fid INTEGER PRIMARY KEY AUTOINCREMENT NOT NULL, geom POLYGON{columns})')
    marks = ", ".join("?" * (len(fields) + 1))
    names = ", ".join(["geom"] + [f'"{f}"' for f in fields])
    rings = [np.asarray(r, np.float64).reshape(-1, 2) for r, _ in features]
    con.executemany(f'INSERT INTO "{table}" ({names}) VALUES ({marks})',
                    [(polygon_blob(r, srs_id), *[_value(a.get(f)) for f in fields]) for r, (_, a) in
                     zip(rings, features)])
    allxy = np.concatenate(rings) if rings else np.zeros((1, 2))
    (x0, y0), (x1, y1) = allxy.min(axis=0), allxy.max(axis=0)
    con.execute("INSERT INTO gpkg_contents (table_name, data_type, identifier, description, min_x, min_y, max_x, "
                "max_y, srs_id) VALUES (?, 'features', ?, ?, ?, ?, ?, ?, ?)",
                (table, table, layer.description, float(x0), float(y0), float(x1), float(y1), srs_id))
    con.execute("INSERT INTO gpkg_geometry_columns VALUES (?, 'geom', 'POLYGON', ?, 0, 0)", (table, srs_id))
    _spatial_index(con, table, rings)


def _spatial_index(con, table, rings):
    """The R*Tree of the features' envelopes (fid = row order + 1), then its triggers."""
    index = f"rtree_{table}_geom"
    try:
        con.execute(f'CREATE VIRTUAL TABLE "{index}" USING rtree(id, minx, maxx, miny, maxy)')
    except sqlite3.OperationalError:  # an SQLite built without R*Tree: the layer stays readable
        warnings.warn(f"this Python's SQLite has no R*Tree module: {table} is written without a spatial index "
                      "(GIS read it whole)", LidarSigWarning, stacklevel=4)
        return
    fids = [row[0] for row in con.execute(f'SELECT fid FROM "{table}" ORDER BY fid')]
    con.executemany(f'INSERT INTO "{index}" VALUES (?, ?, ?, ?, ?)',
                    [(fid, float(r[:, 0].min()), float(r[:, 0].max()), float(r[:, 1].min()), float(r[:, 1].max()))
                     for fid, r in zip(fids, rings)])
    con.executescript(_RTREE_TRIGGERS.format(t=table, i=index))
    con.execute("INSERT INTO gpkg_extensions VALUES (?, 'geom', 'gpkg_rtree_index', ?, 'write-only')", (table, RTREE))


def _write_styles(con, layers):
    """The ``layer_styles`` table (an attributes table of the GeoPackage) with each layer's
    default style."""
    con.executescript(_LAYER_STYLES)
    con.execute("INSERT INTO gpkg_contents (table_name, data_type, identifier, description) VALUES "
                "('layer_styles', 'attributes', 'layer_styles', 'QGIS styles of the layers')")
    con.executemany("INSERT INTO layer_styles (f_table_catalog, f_table_schema, f_table_name, f_geometry_column, "
                    "styleName, styleQML, styleSLD, useAsDefault, description, owner, ui) "
                    "VALUES ('', '', ?, 'geom', ?, ?, '', 1, ?, '', '')",
                    [(layer.name, layer.style_name, layer.style, f"default style of {layer.name} (lidar_sig)")
                     for layer in layers])
